"""Calibration routes: import a thrust-stand table, list imported tables, and ask the
thrust law for a force or a command (``rig import-calibration``, ``rig thrust``)."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, HTTPException, Query, Request
from starlette.concurrency import run_in_threadpool

from api.core.calibration_queries import CalibrationChoice, StandTableQuery, ThrustQuery
from api.http.app_codes import app_router
from api.http.deps import StoreDep, require_read, require_write
from api.http.schemas import csv_upload_body, error_responses
from api.http.uploads import upload_bytes
from daq.calibration_catalog import calibrations, latest, voltage_for
from daq.calibration_law import NoCalibration, import_calibration, law_of

router = app_router("/api", "calibration")

#: The stored name of a table when the query names none.
DEFAULT_NAME = "upload.csv"

_TABLE_BODY = csv_upload_body(
    "CSV with a header: a command column, a thrust column and optionally "
    "a supply-voltage column and the stand's current (A), RPM and power (W) columns "
    "(`,` `;` or tab separated; decimal commas and a BOM read)."
)


@router.post(
    "/calibrations/import",
    status_code=201,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 413, 422),
    openapi_extra=_TABLE_BODY,
)
async def import_table(
    request: Request,
    store: StoreDep,
    query: Annotated[StandTableQuery, Query()],
) -> dict[str, Any]:
    """Store a thrust-stand table as a calibration (no run needed) and return the thrust
    law identified from it (``{id, name, rows, law}``). Current, RPM and power columns are
    kept when named, or when their header says what they are (``Current (A)``, ``RPM``,
    ``Power (W)``); efficiency (N/W) is derived from them."""
    spec = query.spec()
    name = query.name or DEFAULT_NAME
    body = await upload_bytes(request)  # capped by api.http.limits.BodyLimit (UPLOAD_PATHS)
    try:
        return await run_in_threadpool(import_calibration, store, body, spec, name)
    except ValueError as err:
        raise ValueError(f"{name}: {err}") from None


@router.get(
    "/calibrations",
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def list_calibrations(store: StoreDep) -> list[dict[str, Any]]:
    """Every thrust calibration, measured (``source: run``) and imported, newest first,
    without their rows: ``label`` names it for people (``run fc3ab8ab``, ``imported 3
    (T200-16V.csv)``), ``voltages_v`` and ``command_range`` what it covers, ``channels`` the
    stand channels its rows carry besides thrust."""
    return calibrations(store)


@router.get(
    "/calibration/latest",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404),
)
def latest_calibration(store: StoreDep) -> dict[str, Any]:
    """The newest thrust calibration, measured or imported (the one thruster-driven tests
    use): its rows (``data.table``) and the fitted curve and inverse map (``data.fit``)."""
    found = latest(store)
    if found is None:
        raise HTTPException(
            404,
            "no thrust calibration stored yet: run one (rig calibrate-thrusters) or import a "
            "thrust-stand table (rig import-calibration)",
        )
    return found


@router.get(
    "/thrust",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 422),
)
async def thrust(
    store: StoreDep,
    query: Annotated[ThrustQuery, Query()],
    choice: Annotated[CalibrationChoice, Query()],
) -> dict[str, Any]:
    """The thrust law of the newest calibration (or the one ``calibration`` names, as ``rig
    thrust --calibration``): force ± σ at ``command`` and ``voltage_v``, or the command ± σ
    for ``force_n`` (422 naming the largest force full command delivers at that voltage
    when it is beyond)."""
    query.check()
    try:
        law, info = await run_in_threadpool(law_of, store, choice.source, choice.calibration_id)
    except NoCalibration as err:
        raise HTTPException(404, str(err)) from None
    volts, voltage_source = await run_in_threadpool(
        voltage_for, store, law.reference_voltage, query.voltage_v
    )
    answer = query.answer(law, volts)
    return answer | {"voltage_v": volts, "voltage_source": voltage_source, "calibration": info}
