"""Theory routes: water properties at a temperature, and a vehicle's predicted added mass
per DOF (its ``[hull]`` as a primitive in an unbounded fluid) beside its file's values,
with ratio, verdict and, given the tank's width and water depth, the blockage ratio.
Both are computed in the request (microseconds): no job."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Query
from pydantic import Field

from api.core import theory as theory_common
from api.http.app_codes import app_router
from api.http.deps import StoreDep, require_read
from api.http.routes.sixdof import vehicle_with_estimates
from api.http.schemas import error_responses

router = app_router("/api", "theory")


@router.get("/water", dependencies=[Depends(require_read)], responses=error_responses(401, 422))
def get_water(query: Annotated[theory_common.WaterQuery, Query()]) -> dict:
    """ρ (kg/m³), μ (Pa·s) and ν (m²/s) at ``temp_c`` (ITTC 7.5-02-01-03 formulas); with
    ``speed_m_s`` and ``length_m`` also Re = UL/ν and Fr = U/√(gL) under ``flow``. The
    parameters are ``api.core.theory.WaterQuery``'s (``rig water`` too)."""
    return theory_common.water(
        query.temp_c, query.salinity_g_kg, query.speed_m_s, query.length_m, query.g
    )


@router.get(
    "/vehicles/{name}/added-mass",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 422),
)
def get_added_mass(
    name: str,
    store: StoreDep,
    query: Annotated[theory_common.AddedMassQuery, Query()],
    estimates: Annotated[
        list[Annotated[int, Field(ge=1, le=2**62)]],
        Query(max_length=12, description="Stored estimation result ids to compare, in order."),
    ] = [],  # noqa: B006 - FastAPI copies a default list per request
) -> dict:
    """Predicted added mass per DOF of the vehicle's ``[hull]`` (422 when it has none),
    beside ``added_mass.<dof>`` of its file or of the stored ``estimates``: ratio, verdict
    (band 0.5 … 2) and the usual causes of a ratio outside; dimensionless coefficients;
    blockage when both ``tank_width_m`` and ``water_depth_m`` are given. The parameters are
    ``api.core.theory.AddedMassQuery``'s (``rig predict-added-mass`` too)."""
    vehicle, applied = vehicle_with_estimates(store, name, estimates)
    return theory_common.predict(
        vehicle,
        query.water_temp_c,
        query.salinity_g_kg,
        query.tank_width_m,
        query.water_depth_m,
        applied=applied,
    )
