"""Theory routes: water properties at a temperature, and a vehicle's predicted added mass
per DOF (its ``[hull]`` as a primitive in an unbounded fluid) beside its file's values,
with ratio, verdict and, given the tank's width and water depth, the blockage ratio.
Both are computed in the request (microseconds): no job."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Depends, Query
from pydantic import Field

from api.core import theory as theory_common
from api.http.deps import StoreDep, require_read
from api.http.routes.sixdof import vehicle_with_estimates
from api.http.schemas import error_responses
from estimation.water import SALINITY_RANGE_G_KG, TEMPERATURE_RANGE_C

router = APIRouter(prefix="/api", tags=["theory"])
_T_LOW, _T_HIGH = TEMPERATURE_RANGE_C
_S_LOW, _S_HIGH = SALINITY_RANGE_G_KG
_Temperature = Annotated[
    float, Query(ge=_T_LOW, le=_T_HIGH, description="Water temperature, °C (ITTC standard: 15).")
]
_Salinity = Annotated[
    float,
    Query(ge=_S_LOW, le=_S_HIGH, description="Absolute salinity, g/kg (0 = fresh water)."),
]
_Length = Annotated[float | None, Query(gt=0, le=1000, description="m")]


@router.get("/water", dependencies=[Depends(require_read)], responses=error_responses(401, 422))
def get_water(
    temp_c: _Temperature,
    salinity_g_kg: _Salinity = 0.0,
    speed_m_s: Annotated[float | None, Query(ge=-100, le=100, description="m/s")] = None,
    length_m: _Length = None,
    g: Annotated[float, Query(gt=0, le=30, description="m/s²")] = 9.80665,
) -> dict:
    """ρ (kg/m³), μ (Pa·s) and ν (m²/s) at ``temp_c`` (ITTC 7.5-02-01-03 formulas); with
    ``speed_m_s`` and ``length_m`` also Re = UL/ν and Fr = U/√(gL) under ``flow``."""
    return theory_common.water(temp_c, salinity_g_kg, speed_m_s, length_m, g)


@router.get(
    "/vehicles/{name}/added-mass",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 422),
)
def get_added_mass(
    name: str,
    store: StoreDep,
    water_temp_c: _Temperature = theory_common.DEFAULT_WATER_TEMP_C,
    salinity_g_kg: _Salinity = 0.0,
    tank_width_m: _Length = None,
    water_depth_m: _Length = None,
    estimates: Annotated[
        list[Annotated[int, Field(ge=1, le=2**62)]],
        Query(max_length=12, description="Stored estimation result ids to compare, in order."),
    ] = [],  # noqa: B006 - FastAPI copies a default list per request
) -> dict:
    """Predicted added mass per DOF of the vehicle's ``[hull]`` (422 when it has none),
    beside ``added_mass.<dof>`` of its file or of the stored ``estimates``: ratio, verdict
    (band 0.5 … 2) and the usual causes of a ratio outside; dimensionless coefficients;
    blockage when both ``tank_width_m`` and ``water_depth_m`` are given."""
    vehicle, applied = vehicle_with_estimates(store, name, estimates)
    return theory_common.predict(
        vehicle, water_temp_c, salinity_g_kg, tank_width_m, water_depth_m, applied=applied
    )
