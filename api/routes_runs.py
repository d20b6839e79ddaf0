"""Run routes: list with filters, one run, samples (JSON paged, CSV streamed), events,
results, CSV import; estimation/calibration results and report plots."""

from __future__ import annotations

import csv
import io
import math
import re
import tempfile
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, HTTPException, Query, Request
from fastapi.responses import FileResponse, Response, StreamingResponse
from starlette.concurrency import run_in_threadpool

from api.csv_upload import import_file, save_stream
from api.deps import RunnerDep, StoreDep, require_read, require_write
from api.jobs import JobRunner
from api.run_cache import EndedRunCache
from api.schemas import (
    EventOut,
    ImportOut,
    ResultOut,
    RunOut,
    SamplesOut,
    error_responses,
)
from daq.store import ResultNotFound, Store
from daq.vocabulary import RunKind, RunStatus

router = APIRouter(prefix="/api", tags=["runs"])
StatusFilter = Literal[tuple(s.value for s in RunStatus)]  # type: ignore[valid-type]
_READ = error_responses(401, 404, 422)
#: Samples per page of the CSV stream (bounded memory for long runs).
CSV_PAGE = 5000


@router.get(
    "/runs",
    response_model=list[RunOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 422),
)
def list_runs(
    store: StoreDep,
    kind: Annotated[str | None, Query(description=" | ".join(RunKind))] = None,
    status: StatusFilter | None = None,
    vehicle: str | None = None,
    since: Annotated[datetime | None, Query(description="Started at or after (ISO 8601).")] = None,
    until: Annotated[datetime | None, Query(description="Started before (ISO 8601).")] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 100,
    offset: Annotated[int, Query(ge=0, le=1_000_000)] = 0,
) -> list[dict]:
    """Stored runs, newest first."""
    runs = store.list_runs(
        kind=kind,
        status=status,
        vehicle=vehicle,
        since=since,
        until=until,
        limit=limit,
        offset=offset,
    )
    return [r.to_json(include_toml=False) for r in runs]


_RUN_CACHE = EndedRunCache()


@router.get("/runs/{run_id}", response_model=RunOut, dependencies=[Depends(require_read)],
            responses=_READ)  # fmt: skip
async def get_run(
    run_id: str,
    store: StoreDep,
    include_toml: Annotated[
        bool, Query(description="Add the rig file and scenario as run.")
    ] = False,
) -> Response:
    """One run's metadata (id or unique id prefix)."""
    body = _RUN_CACHE.get(run_id, include_toml)
    if body is None:
        run = await run_in_threadpool(store.get_run, run_id)
        body = _RUN_CACHE.put(run, include_toml)
    return Response(body, media_type="application/json")


@router.get(
    "/runs/{run_id}/samples",
    response_model=SamplesOut,
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_samples(
    run_id: str,
    store: StoreDep,
    start_seq: Annotated[int, Query(ge=0, le=2**62)] = 0,
    limit: Annotated[int, Query(ge=1, le=100_000)] = 1000,
) -> dict:
    """A page of samples (columns; SI units; null when a channel was not read)."""
    run = store.get_run(run_id)
    table = store.samples(run.id, start_seq=start_seq, limit=limit + 1)
    more = len(table) > limit
    cols = table.to_json()
    n = min(len(table), limit)
    t0 = _first_t_mono(store, run.id)
    out = {
        "run_id": run.id,
        "start_seq": start_seq,
        "count": n,
        "next_start_seq": int(table.seq[limit]) if more else None,
        "seq": cols["seq"][:n],
        "t": [v - t0 for v in cols["t_mono"][:n]],
        "t_mono": cols["t_mono"][:n],
        "t_wall": cols["t_wall"][:n],
        "quality": cols["quality"][:n],
        "channels": {k: v[:n] for k, v in cols["channels"].items()},
    }
    return out


def _first_t_mono(store: Store, run_id: str) -> float:
    first = store.samples(run_id, limit=1)
    return float(first.t_mono[0]) if len(first) else 0.0


def _csv_rows(store: Store, run_id: str, channels: tuple[str, ...]) -> Iterator[str]:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["t", "seq", "t_mono", "t_wall", "quality", *channels])
    start, t0 = 0, None
    while True:
        table = store.samples(run_id, start_seq=start, limit=CSV_PAGE)
        if not len(table):
            break
        t0 = float(table.t_mono[0]) if t0 is None else t0
        columns = [table.channels[name] for name in channels]
        for i in range(len(table)):
            writer.writerow(
                [
                    repr(float(table.t_mono[i]) - t0),
                    int(table.seq[i]),
                    repr(float(table.t_mono[i])),
                    repr(float(table.t_wall[i])),
                    int(table.quality[i]),
                    *("" if math.isnan(c[i]) else repr(float(c[i])) for c in columns),
                ]
            )
        yield buf.getvalue()
        buf.seek(0)
        buf.truncate()
        if len(table) < CSV_PAGE:
            break
        start = int(table.seq[-1]) + 1
    if buf.getvalue():
        yield buf.getvalue()


@router.get(
    "/runs/{run_id}/samples.csv",
    dependencies=[Depends(require_read)],
    responses={200: {"content": {"text/csv": {}}, "description": "The run as CSV"}} | _READ,
    response_class=StreamingResponse,
)
def get_samples_csv(run_id: str, store: StoreDep) -> StreamingResponse:
    """All samples as CSV (``t`` in s since the first sample, then every channel in SI)."""
    run = store.get_run(run_id)
    return StreamingResponse(
        _csv_rows(store, run.id, run.channel_names),
        media_type="text/csv",
        headers={"Content-Disposition": f'attachment; filename="run-{run.id[:8]}.csv"'},
    )


@router.get(
    "/runs/{run_id}/events",
    response_model=list[EventOut],
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_events(run_id: str, store: StoreDep) -> list[dict]:
    """Operator actions, faults and limit trips of the run, in time order."""
    return [e.to_json() for e in store.events(store.get_run(run_id).id)]


@router.get(
    "/runs/{run_id}/results",
    response_model=list[ResultOut],
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_run_results(run_id: str, store: StoreDep, runner: RunnerDep) -> list[dict]:
    """Estimation and calibration results made from this run."""
    return [_result_json(r, runner) for r in store.results(store.get_run(run_id).id)]


_IMPORT_BODY = {
    "requestBody": {
        "required": True,
        "content": {"text/csv": {"schema": {"type": "string"}}},
        "description": "CSV with a header: t (s), position (m or rad), more columns allowed.",
    }
}


@router.post(
    "/runs/import",
    status_code=201,
    response_model=ImportOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 413, 422),
    openapi_extra=_IMPORT_BODY,
)
async def import_run(
    request: Request,
    kind: Annotated[Literal["tow", "spin"], Query(description="What the CSV recorded.")],
    store: StoreDep,
    force_n: Annotated[float | None, Query(description="Tow force, N (tow runs).")] = None,
    torque_nm: Annotated[float | None, Query(description="Torque, N·m (spin runs).")] = None,
    weight_kg: Annotated[float | None, Query(description="Hung weight, kg (optional).")] = None,
    vehicle: Annotated[str, Query(min_length=1, max_length=200)] = "unknown",
    filename: Annotated[str, Query(min_length=1, max_length=200)] = "upload.csv",
    time_unit: Annotated[
        Literal["s", "ms", "us"], Query(description="Unit of the t column.")
    ] = "s",
    release_time_s: Annotated[
        float | None,
        Query(description="Brake release, s on the t axis (default: found in the data)."),
    ] = None,
    end_time_s: Annotated[
        float | None,
        Query(description="End of free motion, s on the t axis (default: found in the data)."),
    ] = None,
) -> dict:
    """Import a CSV recorded elsewhere as a completed run (body = the CSV text, at most
    ``max_upload_bytes`` and ``MAX_IMPORT_ROWS`` rows; parsed in a separate process).

    Estimation finds the release and the end of free motion from the
    ``tow_release``/``spin_release``/``end_of_travel`` columns when present, else from the
    motion; ``release_time_s``/``end_time_s`` override that."""
    load = {"tow": ("force_n", force_n), "spin": ("torque_nm", torque_nm)}[kind]
    params: dict = {load[0]: load[1]} if load[1] is not None else {}
    if weight_kg is not None:
        params["hung_mass_kg"] = weight_kg
    name = re.sub(r"[^A-Za-z0-9._-]", "_", Path(filename).name) or "upload.csv"
    with tempfile.TemporaryDirectory(prefix="rig-import-") as folder:
        path = Path(folder) / name
        await save_stream(request.stream(), path)  # the size cap is api.limits.BodyLimit's
        try:
            run_id, samples = await import_file(
                store,
                path,
                kind=kind,
                parameters=params,
                vehicle=vehicle,
                time_unit=time_unit,
                release_time_s=release_time_s,
                end_time_s=end_time_s,
            )
        except ValueError as err:
            message = str(err).replace(str(path), name)
            if "line" in message and not message.startswith(name):
                message = f"{name}: {message}"
            raise ValueError(message) from None
    return {"run_id": run_id, "samples": samples}


# ---- results ----------------------------------------------------------------------------------
def _result_json(result, runner: JobRunner) -> dict:
    data = result.to_json()
    folder = runner.report_root / f"result-{result.id}"
    data["report_plots"] = sorted(p.stem for p in folder.glob("*.png")) if folder.is_dir() else []
    return data


@router.get(
    "/results",
    response_model=list[ResultOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 422),
)
def list_results(
    store: StoreDep,
    runner: RunnerDep,
    kind: Literal["estimation", "calibration"] | None = None,
) -> list[dict]:
    """Estimation and calibration results, newest first."""
    return [_result_json(r, runner) for r in reversed(store.results(kind=kind))]


def _find_result(store: Store, result_id: int):
    try:
        return store.result(result_id)
    except ResultNotFound as err:
        raise HTTPException(404, str(err)) from None


@router.get(
    "/results/{result_id}",
    response_model=ResultOut,
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_result(result_id: int, store: StoreDep, runner: RunnerDep) -> dict:
    """One result (estimation JSON of issue 4, or a thrust calibration with its inverse map)."""
    return _result_json(_find_result(store, result_id), runner)


@router.get(
    "/calibration/latest",
    response_model=ResultOut,
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404),
)
def latest_calibration(store: StoreDep, runner: RunnerDep) -> dict:
    """The newest thrust calibration: table, fitted curve and inverse map."""
    latest = store.latest_result("calibration")
    if latest is None:
        raise HTTPException(404, "no thrust calibration stored yet; run one first")
    return _result_json(latest, runner)


@router.get(
    "/results/{result_id}/report/{name}.png",
    dependencies=[Depends(require_read)],
    responses={200: {"content": {"image/png": {}}, "description": "A report plot"}} | _READ,
    response_class=FileResponse,
)
def get_report_plot(
    result_id: int,
    name: str,
    store: StoreDep,
    runner: RunnerDep,
) -> FileResponse:
    """A PNG of an estimation report made by this service (names in ``report_plots``)."""
    _find_result(store, result_id)
    path = runner.report_file(result_id, name)
    if path is None:
        raise HTTPException(404, f"result {result_id} has no report plot named {name!r}")
    return FileResponse(path, media_type="image/png")
