"""Run routes: list with filters, one run, samples (JSON paged, CSV streamed), export
(CSV, JSON, NetCDF, Parquet), events. The CSV import is ``api.http.routes.imports``; the
results made from runs are ``api.http.routes.results``.

One module because every route here is under /api/runs and shares the id resolution (404
for unknown or malformed ids) and the error bodies.
"""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, Query
from fastapi.responses import FileResponse, Response, StreamingResponse
from starlette.background import BackgroundTask
from starlette.concurrency import run_in_threadpool

from api.core.export_request import ExportQuery
from api.core.paging import RunsPage, SamplesPage
from api.core.run_cache import EndedRunCache
from api.core.run_filter import RunFilter
from api.http.app_codes import app_router
from api.http.deps import RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import (
    EventOut,
    RunOut,
    SamplesOut,
    error_responses,
    file_response,
)
from daq.export_formats import FORMATS, FormatInfo, export_file_name, write_export
from daq.procedures.requests import RunMetadataIn
from daq.store import Store
from daq.store.channel_units import column_infos
from daq.store.csv_export import csv_chunks

router = app_router("/api", "runs")
_READ = error_responses(401, 404, 422)


@router.get(
    "/runs",
    response_model=list[RunOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 422),
)
def list_runs(
    store: StoreDep,
    response: Response,
    run_filter: Annotated[RunFilter, Query()],
    page: Annotated[RunsPage, Query()],
) -> list[dict]:
    """Stored runs, newest first, a page at a time: the ``X-Total-Count`` header gives how
    many match the filters, ``X-Next-Offset`` the ``offset`` of the next page (absent on
    the last). The filters and the page are ``api.core.run_filter.RunFilter``'s and
    ``api.core.paging.RunsPage``'s (``rig runs`` too)."""
    filters, offset = run_filter.store_filters(), page.offset
    runs = store.list_runs(**filters, limit=page.limit, offset=offset)
    total = store.count_runs(**filters)
    response.headers["X-Total-Count"] = str(total)
    if offset + len(runs) < total:
        response.headers["X-Next-Offset"] = str(offset + len(runs))
    return [r.to_json(include_toml=False) for r in runs]


@router.patch(
    "/runs/{run_id}/metadata",
    response_model=RunOut,
    dependencies=[Depends(require_write)],
    responses=_READ,
)
def patch_run_metadata(run_id: str, body: RunMetadataIn, store: StoreDep) -> dict:
    """Annotate a run (any status, imported too): the keys given replace the stored ones,
    ``null`` removes a key, ``tags`` replaces the tag list. Returns the run."""
    run = store.set_run_metadata(run_id, body.model_dump(exclude_unset=True))
    return run.to_json(include_toml=False)


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
    body = await run_in_threadpool(_RUN_CACHE.get, run_id, include_toml, store.stored_metadata)
    if body is None:
        run = await run_in_threadpool(store.get_run, run_id)
        stored = store.pending_ends.get(run.id) is None
        body = _RUN_CACHE.put(run, include_toml, stored=stored)
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
    page: Annotated[SamplesPage, Query()],
    start_seq: Annotated[int, Query(ge=0, le=2**62)] = 0,
) -> dict:
    """A page of samples (columns; SI units; null when a channel was not read)."""
    limit = page.limit
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
        "units": {k: c.units for k, c in column_infos(run).items() if k in cols["channels"]},
    }
    return out


def _first_t_mono(store: Store, run_id: str) -> float:
    first = store.samples(run_id, limit=1)
    return float(first.t_mono[0]) if len(first) else 0.0


def _attachment(run_id: str, fmt: str) -> dict[str, str]:
    return {"Content-Disposition": f'attachment; filename="{export_file_name(run_id, fmt)}"'}


@router.get(
    "/runs/{run_id}/samples.csv",
    dependencies=[Depends(require_read)],
    responses=file_response({"text/csv": {}}, "The run as CSV") | _READ,
    response_class=StreamingResponse,
)
def get_samples_csv(run_id: str, store: StoreDep) -> StreamingResponse:
    """All samples as CSV, as ``/runs/{id}/export?format=csv`` (``#`` comment lines with
    the run and ``# units: …``, then ``t`` in s since the first sample and every channel
    in SI)."""
    run = store.get_run(run_id)
    return StreamingResponse(
        csv_chunks(store, run.id), media_type="text/csv", headers=_attachment(run.id, "csv")
    )


_EXPORT_CONTENT: dict[str, dict[str, Any]] = {f.media_type: {} for f in FORMATS.values()}


@router.get(
    "/export-formats",
    response_model=list[FormatInfo],
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def list_export_formats() -> list[dict[str, str | bool]]:
    """The formats ``/runs/{id}/export`` writes: name, suffix, media type, label, help,
    binary (the browser's export menu is built from this list)."""
    return [f.public() for f in FORMATS.values()]


@router.get(
    "/runs/{run_id}/export",
    dependencies=[Depends(require_read)],
    responses=file_response(_EXPORT_CONTENT, "The run as a file") | _READ,
    response_class=FileResponse,
)
def export_run(
    run_id: str,
    store: StoreDep,
    runner: RunnerDep,
    query: Annotated[ExportQuery, Query()],
) -> Response:
    """The run as a file to download in a format of ``GET /api/export-formats`` (CSV is
    streamed). The file is written in the analysis worker process, not the rig's. The query
    is ``rig export``'s options (``api.core.export_request.ExportQuery``)."""
    fmt = query.format
    run = store.get_run(run_id)
    if fmt == "csv":
        return get_samples_csv(run.id, store)
    folder = tempfile.mkdtemp(prefix="rig-export-")
    target = Path(folder) / export_file_name(run.id, fmt)
    try:
        path = runner.analysis.executor_for(store).call(
            store.url, write_export, run.id, fmt, target
        )
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return FileResponse(
        path,
        media_type=FORMATS[fmt].media_type,
        filename=path.name,
        background=BackgroundTask(shutil.rmtree, folder, ignore_errors=True),
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
