"""Calibration routes: import a thrust-stand table, list imported tables, and ask the
thrust law for a force or a command (``rig import-calibration``, ``rig thrust``)."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, HTTPException, Query, Request
from starlette.concurrency import run_in_threadpool

from api.http.deps import StoreDep, require_read, require_write
from api.http.schemas import csv_upload_body, error_responses
from api.http.uploads import upload_bytes
from daq.calibration_catalog import calibrations, latest, voltage_for
from daq.calibration_law import NoCalibration, import_calibration, law_of
from estimation.thrust.calibration_import import CommandUnit, ImportSpec, stand_columns

router = APIRouter(prefix="/api", tags=["calibration"])

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
    command_column: Annotated[str, Query(max_length=200, description="Header or number.")] = "1",
    command_unit: Annotated[
        Literal["pwm_us", "permille", "fraction", "volts"], Query()
    ] = "fraction",
    pwm_neutral_us: float = 1500.0,
    pwm_span_us: float = 400.0,
    full_scale_v: float | None = None,
    thrust_column: Annotated[str, Query(max_length=200)] = "2",
    thrust_unit: Annotated[Literal["N", "kgf", "gf", "lbf"], Query()] = "N",
    voltage_column: Annotated[str | None, Query(max_length=200)] = None,
    voltage_v: float | None = None,
    current_column: Annotated[str | None, Query(max_length=200)] = None,
    rpm_column: Annotated[str | None, Query(max_length=200)] = None,
    power_column: Annotated[str | None, Query(max_length=200)] = None,
    name: Annotated[str, Query(min_length=1, max_length=200)] = "upload.csv",
) -> dict[str, Any]:
    """Store a thrust-stand table as a calibration (no run needed) and return the thrust
    law identified from it (``{id, name, rows, law}``). Current, RPM and power columns are
    kept when named, or when their header says what they are (``Current (A)``, ``RPM``,
    ``Power (W)``); efficiency (N/W) is derived from them."""
    spec = ImportSpec(
        command_column=command_column,
        thrust_column=thrust_column,
        thrust_unit=thrust_unit,
        command=CommandUnit(command_unit, pwm_neutral_us, pwm_span_us, full_scale_v),
        voltage_column=voltage_column,
        voltage_v=voltage_v,
        extra_columns=stand_columns(current_a=current_column, rpm=rpm_column, power_w=power_column),
    )
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
    command: Annotated[
        float | None, Query(ge=-1, le=1, description="Command, fraction: give the force.")
    ] = None,
    force_n: Annotated[
        float | None, Query(description="Force per thruster, N: give the command.")
    ] = None,
    voltage_v: Annotated[
        float | None,
        Query(
            gt=0,
            le=1000,
            description="Supply voltage (default: the supply the rig recorded last, else the "
            "calibration's reference voltage; ``voltage_source`` says which).",
        ),
    ] = None,
    source: Annotated[Literal["imported", "run"] | None, Query()] = None,
    calibration_id: Annotated[int | None, Query(ge=1)] = None,
) -> dict[str, Any]:
    """The thrust law of the newest calibration (or ``source`` + ``calibration_id``): force
    ± σ at ``command`` and ``voltage_v``, or the command ± σ for ``force_n`` (422 naming the
    largest force full command delivers at that voltage when it is beyond)."""
    if (command is None) == (force_n is None):
        raise ValueError("command or force_n: give exactly one")
    if force_n is not None and not math.isfinite(force_n):
        raise ValueError(f"force_n: got {force_n}, allowed: a finite force in N")
    try:
        law, info = await run_in_threadpool(law_of, store, source, calibration_id)
    except NoCalibration as err:
        raise HTTPException(404, str(err)) from None
    volts, voltage_source = await run_in_threadpool(
        voltage_for, store, law.reference_voltage, voltage_v
    )
    if command is not None:
        out = law.estimate(command, volts)
        answer: dict[str, Any] = {"command": command, "force_n": out.to_json()}
    else:
        assert force_n is not None  # exactly one of the two is given (checked above)
        try:
            out = law.command_for_force(force_n, volts)
        except ValueError as err:
            raise ValueError(f"force_n: {str(err).removeprefix('force: ')}") from None
        answer = {"force_n": force_n, "command": out.to_json()}
    return answer | {
        "voltage_v": volts,
        "voltage_source": voltage_source,
        "calibration": info,
        "voltage_law": out.voltage_law,
    }
