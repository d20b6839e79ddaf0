"""What ``rig predict-added-mass``, ``rig water`` and their HTTP routes share: water at a
temperature, and a vehicle's predicted added mass per DOF beside the values its file
holds (measured or placeholder), with the ratio, the verdict and the blockage."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from estimation import scale
from estimation.theory.compare import DEFAULT_BAND, compare_added_mass
from estimation.theory.hull import predict_added_mass
from estimation.theory.tank import blockage
from estimation.vehicle.description import DOFS, Vehicle6
from estimation.water import water_properties

#: Water temperature used when none is given: ITTC's standard temperature for fresh water.
DEFAULT_WATER_TEMP_C = 15.0


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
