"""``POST /api/runs/import``: a CSV recorded elsewhere (or a towrig export) as a completed run.

The import's rules (kind, drive, rig limits, the export's header) are
``api.core.imports``'s, shared with ``rig import``; this is the route's face: the query,
the streamed body, the parse in a child process (``api.core.csv_upload``). The kinds and
each kind's own query parameters (a free decay's ``dof``) are the registry's
(``daq.procedures.run_kinds.IMPORT_KINDS``, ``import_fields``).
"""

from __future__ import annotations

import re
import tempfile
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, Query, Request

from api.core.csv_upload import import_file
from api.core.imports import ImportRequest, plan_import
from api.http.deps import ServiceDep, StoreDep, require_write
from api.http.schemas import ImportOut, csv_upload_body, error_responses
from api.http.uploads import save_upload
from daq.procedures.params import ParameterError
from daq.procedures.run_kinds import IMPORT_KINDS, import_fields
from daq.store.run_metadata import check_run_metadata, check_tag

router = APIRouter(prefix="/api", tags=["runs"])


_IMPORT_BODY = csv_upload_body(
    "CSV with a header: t (s), position (m or rad), more columns allowed "
    "(a drive logged per sample among them, named by drive_column)."
)


ImportKind = Literal[tuple(str(k) for k in IMPORT_KINDS)]  # type: ignore[valid-type]


def _kind_parameters() -> list[dict[str, Any]]:
    """The kinds' own import fields as OpenAPI query parameters (their JSON Schemas)."""
    schema = import_fields().model_json_schema()
    return [
        {"name": name, "in": "query", "required": False, "schema": field,
         "description": field.get("description", "")}
        for name, field in schema.get("properties", {}).items()
    ]  # fmt: skip


def _kind_fields(request: Request) -> dict[str, Any]:
    """The kinds' own import fields the query gives (checked by the kind's rule)."""
    names = import_fields().model_fields
    return {k: v for k, v in request.query_params.items() if k in names}


#: The stored file name when neither the query nor a multipart part names one.
DEFAULT_NAME = "upload.csv"


def _safe_name(filename: str, field: str = "filename") -> str:
    """The uploaded file's name, checked to be a plain file name (no folder, not ``.`` or
    ``..``, no NUL) and made of safe characters, so it never reaches the file system as a
    path; 422 naming ``field`` otherwise."""
    if filename in (".", "..") or any(c in filename for c in "/\\\0") or not filename.strip(". "):
        raise ValueError(
            f"{field}: {filename!r} is not allowed; give the file's name alone, without "
            "folders (e.g. tow-24N.csv)"
        )
    return re.sub(r"[^A-Za-z0-9._-]", "_", filename)


def _import_metadata(
    operator: str | None, water: float | None, notes: str | None, tags: list[str] | None
) -> dict | None:
    """The import's metadata query parameters, checked before the body is read (errors
    name the query parameter)."""
    given = {"operator": operator, "water_temperature_c": water, "notes": notes}
    metadata: dict[str, Any] = {key: value for key, value in given.items() if value is not None}
    if tags:
        metadata["tags"] = [check_tag("tag", t) for t in tags]
    return check_run_metadata(metadata, prefix="") or None


@router.post(
    "/runs/import",
    status_code=201,
    response_model=ImportOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 413, 422),
    openapi_extra=_IMPORT_BODY | {"parameters": _kind_parameters()},
)
async def import_run(
    request: Request,
    store: StoreDep,
    service: ServiceDep,
    kind: Annotated[
        ImportKind | None,  # type: ignore[valid-type]  # the registry's import kinds
        Query(description="What the CSV recorded (default: what a towrig export's header says)."),
    ] = None,
    force_n: Annotated[
        float | None, Query(description="Tow force, N (tow runs; negative: a reverse tow).")
    ] = None,
    torque_nm: Annotated[
        float | None, Query(description="Torque, N·m (spin runs; negative: a reverse spin).")
    ] = None,
    drive_column: Annotated[
        str | None,
        Query(
            min_length=1,
            max_length=200,
            description="Column of the force (tow) or torque (spin) logged per sample, "
            "instead of force_n/torque_nm.",
        ),
    ] = None,
    drive_unit: Annotated[
        str | None,
        Query(
            max_length=20,
            description="Unit of drive_column: N, kN, kgf, gf, lbf (tow); N·m, kgf·m, … "
            "(spin). Default N or N·m.",
        ),
    ] = None,
    weight_kg: Annotated[float | None, Query(description="Hung weight, kg (optional).")] = None,
    dry_mass_kg: Annotated[
        float | None,
        Query(description="Tow: the body's own mass, kg (estimation flags an inertia below it)."),
    ] = None,
    displacement_kg: Annotated[
        float | None,
        Query(description="Tow: mass of water the body displaces, kg (a floating body's mass)."),
    ] = None,
    vehicle: Annotated[
        str | None,
        Query(min_length=1, max_length=200, description="Default: the export's, else unknown."),
    ] = None,
    filename: Annotated[str, Query(min_length=1, max_length=200)] = DEFAULT_NAME,
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
    operator: Annotated[str | None, Query(description="Run metadata: who ran the test.")] = None,
    water_temperature_c: Annotated[
        float | None, Query(description="Run metadata: water temperature, °C (-2…50).")
    ] = None,
    notes: Annotated[str | None, Query(description="Run metadata: free notes.")] = None,
    tag: Annotated[list[str] | None, Query(description="Run metadata: a tag (repeatable).")] = None,
) -> dict:
    """Import a CSV recorded elsewhere as a completed run (body = the CSV text, at most
    ``max_upload_bytes`` and ``MAX_IMPORT_ROWS`` rows; parsed in a separate process).

    Estimation finds the release and the end of free motion from the
    ``tow_release``/``spin_release``/``end_of_travel`` columns when present, else from the
    motion; ``release_time_s``/``end_time_s`` override that. ``operator``,
    ``water_temperature_c``, ``notes`` and ``tag`` update the file's ``# metadata:`` line.
    ``drive_column`` names a drive logged per sample. A pendulum decay (angle in rad) is
    stored with the rig file the service runs with (its ``[pendulum]`` geometry). A constant
    load whose sign disagrees with the recorded motion is refused; a towrig export imports
    back as it was (kind, load, hung weight, release, vehicle from its header, listed in
    ``from_header``). The rules are ``api.core.imports``'s, shared with ``rig import``."""
    metadata = _import_metadata(operator, water_temperature_c, notes, tag)
    request_ = ImportRequest(
        kind=kind, force_n=force_n, torque_nm=torque_nm, drive_column=drive_column,
        drive_unit=drive_unit, weight_kg=weight_kg, vehicle=vehicle, time_unit=time_unit,
        release_time_s=release_time_s, end_time_s=end_time_s, dry_mass_kg=dry_mass_kg,
        displacement_kg=displacement_kg, fields=_kind_fields(request),
    )  # fmt: skip
    name = _safe_name(filename)
    with tempfile.TemporaryDirectory(prefix="rig-import-") as folder:
        path = Path(folder) / name  # a name, never a path: it stays in the folder
        sent_as = await save_upload(request, path)  # the size cap is BodyLimit's
        if sent_as and filename == DEFAULT_NAME:  # a multipart part names its file
            base = re.split(r"[/\\]", sent_as)[-1]  # some clients send the whole path
            name = _safe_name(base, "the multipart part's filename")
            path = path.rename(Path(folder) / name)  # a name: it stays in the folder
        try:
            plan = plan_import(path, request_, pendulum_rig=service.source, rig_field="kind")
            run_id, samples = await import_file(
                store, path, kind=plan.kind, metadata=metadata, **plan.options
            )
        except ValueError as err:
            if isinstance(err, ParameterError):
                raise
            message = str(err).replace(str(path), name)
            if "line" in message and not message.startswith(name):
                message = f"{name}: {message}"
            raise ValueError(message) from None
    return {"run_id": run_id, "samples": samples, "from_header": plan.from_header}
