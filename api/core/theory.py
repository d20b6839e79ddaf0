"""What ``rig predict-added-mass``, ``rig water`` and their HTTP routes share: water at a
temperature, and a vehicle's predicted added mass per DOF beside the values its file
holds (measured or placeholder), with the ratio, the verdict and the blockage."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Any

from pydantic import BaseModel, Field

from daq.procedures.flag import Flag
from estimation import scale
from estimation.theory.compare import DEFAULT_BAND, compare_added_mass
from estimation.theory.hull import predict_added_mass
from estimation.theory.tank import blockage
from estimation.vehicle.description import DOFS, Vehicle6
from estimation.water import (
    DEFAULT_WATER_TEMP_C,
    SALINITY_RANGE_G_KG,
    TEMPERATURE_RANGE_C,
    water_properties,
)

_T_LOW, _T_HIGH = TEMPERATURE_RANGE_C
_S_LOW, _S_HIGH = SALINITY_RANGE_G_KG
_SALINITY = Field(
    ge=_S_LOW, le=_S_HIGH,
    description="Absolute salinity, g/kg (0 = fresh water, 35.165 = standard sea water).",
)  # fmt: skip


class WaterQuery(BaseModel):
    """The water asked about, declared once for ``GET /api/water`` and ``rig water``."""

    temp_c: Annotated[
        float,
        Field(ge=_T_LOW, le=_T_HIGH, description="Water temperature, °C."),
        Flag("--temp", metavar="C"),
    ]
    salinity_g_kg: Annotated[float, _SALINITY, Flag("--salinity", metavar="G_PER_KG")] = 0.0
    speed_m_s: Annotated[
        float | None,
        Field(
            ge=-100, le=100, description="Speed, m/s (with a body length: Re = UL/ν, Fr = U/√(gL))."
        ),
        Flag("--speed", metavar="M_PER_S"),
    ] = None
    length_m: Annotated[
        float | None,
        Field(gt=0, le=1000, description="Body length, m."),
        Flag("--length", metavar="M"),
    ] = None
    g: Annotated[
        float, Field(gt=0, le=30, description="Local gravity for Fr, m/s²."), Flag("--g")
    ] = scale.STANDARD_GRAVITY


class AddedMassQuery(BaseModel):
    """The water and the tank of an added-mass prediction, declared once for
    ``GET /api/vehicles/{name}/added-mass`` and ``rig predict-added-mass``."""

    water_temp_c: Annotated[
        float,
        Field(ge=_T_LOW, le=_T_HIGH, description="Water temperature, °C (ITTC standard: 15)."),
        Flag("--water-temp", metavar="C"),
    ] = DEFAULT_WATER_TEMP_C
    salinity_g_kg: Annotated[float, _SALINITY, Flag("--salinity", metavar="G_PER_KG")] = 0.0
    tank_width_m: Annotated[
        float | None,
        Field(
            gt=0, le=1000, description="Tank width, m (with the water depth: the blockage ratio)."
        ),
        Flag("--tank-width", metavar="M"),
    ] = None
    water_depth_m: Annotated[
        float | None,
        Field(gt=0, le=1000, description="Water depth, m."),
        Flag("--water-depth", metavar="M"),
    ] = None


class NoHull(ValueError):
    """The vehicle file has no ``[hull]`` table."""


def water(
    temperature_c: float,
    salinity_g_kg: float = 0.0,
    speed_m_s: float | None = None,
    length_m: float | None = None,
    g: float = scale.STANDARD_GRAVITY,
) -> dict[str, Any]:
    """ρ, μ, ν of the water and, given a speed and a length, Re and Fr (ValueError naming
    the field when out of range)."""
    if (speed_m_s is None) != (length_m is None):
        raise ValueError("speed_m_s/length_m: got one of the two, allowed: both or neither")
    w = water_properties(temperature_c, salinity_g_kg)
    out: dict[str, Any] = w.to_json()
    if speed_m_s is not None and length_m is not None:
        flow = scale.flow_numbers(speed_m_s, length_m, w.kinematic_viscosity, g)
        out["flow"] = {
            "speed_m_s": flow.speed_m_s,
            "length_m": flow.length_m,
            "g": g,
            "reynolds": flow.reynolds,
            "froude": flow.froude,
        }
    return out


def predict(
    vehicle: Vehicle6,
    temperature_c: float = DEFAULT_WATER_TEMP_C,
    salinity_g_kg: float = 0.0,
    tank_width_m: float | None = None,
    water_depth_m: float | None = None,
    band: tuple[float, float] = DEFAULT_BAND,
    applied: Sequence[dict[str, Any]] = (),
) -> dict[str, Any]:
    """The vehicle's predicted added mass per DOF in an unbounded fluid, beside the value
    it holds (``added_mass.<dof>``: its file's, or a stored estimation result's when
    ``applied`` — ``sixdof.apply_results``' list — says one was plugged in): ratio and
    verdict per DOF, dimensionless coefficients, and the blockage when the tank's width
    and water depth are given."""
    if vehicle.hull is None:
        raise NoHull(
            f"vehicle {vehicle.name!r}: hull: got None, allowed: a [hull] table "
            "(shape and dimensions; docs/sixdof.md, 'Vehicle file')"
        )
    if (tank_width_m is None) != (water_depth_m is None):
        raise ValueError("tank_width_m/water_depth_m: got one of the two, allowed: both or neither")
    w = water_properties(temperature_c, salinity_g_kg)
    prediction = predict_added_mass(vehicle.hull, w.density)
    hull = vehicle.hull
    volume = hull.displaced_volume_m3 or prediction.added_mass.displaced_volume_m3
    area = hull.reference_area_m2 or hull.frontal_area_m2
    in_file = vehicle.coefficients()
    sources = {a["axis"]: f"result {a['result_id']}" for a in applied}
    rows = []
    for i, dof in enumerate(DOFS):
        predicted = prediction.added_mass.values[dof]
        measured = in_file[f"added_mass.{dof}"]
        row: dict[str, Any] = {
            "dof": dof,
            "unit": "kg" if i < 3 else "kg·m²",
            "predicted": predicted,
            "coefficient_predicted": prediction.added_mass.coefficients[dof],
            "value": measured,
            "source": sources.get(dof, "vehicle file"),
            "sigma": vehicle.sigma.get(f"added_mass.{dof}"),
        }
        # The value made dimensionless as estimation/scale.py states (the predicted
        # coefficient is Lamb's: over the primitive's displaced mass or inertia).
        if i < 3:
            c = scale.added_mass_coefficient(measured, w.density, volume)
            row["dimensionless"] = {"value": c, "convention": "m_a / (ρ ∇)"}
        else:
            c = scale.added_inertia_coefficient(measured, w.density, volume, hull.length_m)
            row["dimensionless"] = {"value": c, "convention": "I_a / (ρ ∇ L²)"}
        if predicted is not None and predicted > 0:
            row["verdict"] = compare_added_mass(measured, predicted, band).to_json()
        else:
            row["verdict"] = None
        rows.append(row)
    surge_drag = vehicle.coefficients()["quadratic_damping.surge"]
    out: dict[str, Any] = {
        "vehicle": vehicle.name,
        "file": vehicle.source,
        "water": w.to_json(),
        "prediction": prediction.to_json(),
        "dofs": rows,
        "band": list(band),
        "applied_estimates": list(applied),
        "dimensionless": {
            "volume_m3": volume,
            "length_m": hull.length_m,
            "reference_area_m2": area,
            "reference_area_declared": hull.reference_area_m2 is not None,
            "surge_drag_coefficient": scale.drag_coefficient(surge_drag, w.density, area),
            "added_inertia_convention": "C_I = I_a / (ρ ∇ L²)",
        },
        "blockage": None,
    }
    if tank_width_m is not None and water_depth_m is not None:
        out["blockage"] = blockage(hull.frontal_area_m2, tank_width_m, water_depth_m).to_json()
    return out
