"""``POST /api/runs/import``: a CSV recorded elsewhere (or a towrig export) as a completed run.

The import's rules (kind, drive, rig limits, the export's header) are
``api.core.imports``'s, shared with ``rig import``; this is the route's face: the query,
the streamed body, the parse in a child process (``api.core.csv_upload``). The query
parameters of the file's facts are ``api.core.imports.ImportQuery``'s, those of the run's
metadata ``api.core.run_metadata_query.RunMetadataQuery``'s, as ``rig import``'s options
are. The kinds and
each kind's own query parameters (a free decay's ``dof``) are the registry's
(``daq.procedures.run_kinds.IMPORT_KINDS``, ``import_fields``).
"""

from __future__ import annotations

import re
import tempfile
from pathlib import Path
from typing import Annotated, Any

from fastapi import Depends, Query, Request

from api.core.csv_upload import import_file
from api.core.imports import ImportQuery, plan_import
from api.core.run_metadata_query import RunMetadataQuery
from api.http.app_codes import app_router
from api.http.deps import ServiceDep, StoreDep, require_write
from api.http.schemas import ImportOut, csv_upload_body, error_responses
from api.http.uploads import save_upload
from daq.procedures.params import ParameterError
from daq.procedures.run_kinds import import_fields

router = app_router("/api", "runs")


_IMPORT_BODY = csv_upload_body(
    "CSV with a header: t (s), position (m or rad), more columns allowed "
    "(a drive logged per sample among them, named by drive_column)."
)


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
    query: Annotated[ImportQuery, Query()],
    run_metadata: Annotated[RunMetadataQuery, Query()],
    filename: Annotated[str, Query(min_length=1, max_length=200)] = DEFAULT_NAME,
) -> dict:
    """Import a CSV recorded elsewhere as a completed run (body = the CSV text, at most
    ``max_upload_bytes`` and ``MAX_IMPORT_ROWS`` rows; parsed in a separate process).

    Estimation finds the release and the end of free motion from the
    ``tow_release``/``spin_release``/``end_of_travel`` columns when present, else from the
    motion; ``release_time_s``/``end_time_s`` override that. The run metadata parameters
    (``operator``, ``tag``, ``meta``, …: ``RunMetadataQuery``, ``rig import``'s options too)
    update the file's ``# metadata:`` line.
    ``drive_column`` names a drive logged per sample. A pendulum decay (angle in rad) is
    stored with the rig file the service runs with (its ``[pendulum]`` geometry). A constant
    load whose sign disagrees with the recorded motion is refused; a towrig export imports
    back as it was (kind, load, hung weight, release, vehicle from its header, listed in
    ``from_header``). The rules are ``api.core.imports``'s, shared with ``rig import``."""
    metadata = run_metadata.metadata() or None  # checked before the body is read
    name = _safe_name(filename)
    with tempfile.TemporaryDirectory(prefix="rig-import-") as folder:
        path = Path(folder) / name  # a name, never a path: it stays in the folder
        sent_as = await save_upload(request, path)  # the size cap is BodyLimit's
        if sent_as and filename == DEFAULT_NAME:  # a multipart part names its file
            base = re.split(r"[/\\]", sent_as)[-1]  # some clients send the whole path
            name = _safe_name(base, "the multipart part's filename")
            path = path.rename(Path(folder) / name)  # a name: it stays in the folder
        try:
            plan = plan_import(
                path,
                query,
                fields=_kind_fields(request),
                pendulum_rig=service.source,
                rig_field="kind",
            )
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
