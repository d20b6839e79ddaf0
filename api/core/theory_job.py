"""Measured beside theory for an estimation job: the rig's vehicle file (its ``[hull]``), the
runs' water (temperature and salinity from their metadata, else ITTC's 15 °C fresh water)
and the runs' terminal speeds handed to ``estimation.theory.measured`` as plain numbers;
appended to report.md with a flag when the measured added mass is implausible for the hull
(seed 000's 113 kg)."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from api.core.vehicle_files import VehicleNotFound, find_vehicle, vehicle_files
from daq.axis_budget import rig_of_runs
from daq.store import RunInfo
from estimation.stats.repeatability import RepeatAnalysis
from estimation.theory.hull import predict_added_mass
from estimation.theory.measured import HullScale, measured_beside_theory, theory_markdown
from estimation.water import DEFAULT_WATER_TEMP_C, WaterError, water_properties


def water_of_runs(records: Sequence[RunInfo]) -> tuple[float, float, str]:
    """The water of the runs' ``records``: their mean recorded temperature (°C; else ITTC's
    standard 15 °C), their mean recorded absolute salinity (g/kg; else fresh water, 0), and
    where each came from."""
    metadata = [run.metadata for run in records]
    temps = [float(t) for m in metadata if (t := m.get(TEMP)) is not None]
    salts = [float(s) for m in metadata if (s := m.get(SALINITY)) is not None]
    temp = sum(temps) / len(temps) if temps else DEFAULT_WATER_TEMP_C
    salinity = sum(salts) / len(salts) if salts else 0.0
    source = "run metadata" if temps else "not recorded: ITTC's standard 15 °C"
    source += "; salinity from run metadata" if salts else "; fresh water (no salinity recorded)"
    return temp, salinity, source


#: The vehicle file's ``[tolerances]`` keys (±a, rectangular).
VEHICLE_TOLERANCES = ("mass_kg", "yaw_inertia_kg_m2", "displaced_volume_m3", "length_m")
TEMP = "water_temperature_c"
SALINITY = "salinity_g_kg"


def vehicle_tolerances(path: Path | None) -> dict[str, float]:
    """Standard uncertainties u = a/√3 of the vehicle file's ``[tolerances]`` (ValueError
    naming the field for an unknown key or a value that is not a finite number ≥ 0)."""
    if path is None or not path.is_file():
        return {}
    table = tomllib.loads(path.read_text(encoding="utf-8")).get("tolerances", {})
    out = {}
    for key, value in table.items():
        if key not in VEHICLE_TOLERANCES:
            allowed = ", ".join(VEHICLE_TOLERANCES)
            raise ValueError(f"{path.name}: tolerances.{key}: got {key!r}, allowed: {allowed}")
        if isinstance(value, bool) or not isinstance(value, int | float) or not value >= 0:
            raise ValueError(f"{path.name}: tolerances.{key}: got {value!r}, allowed: >= 0")
        out[key] = float(value) / math.sqrt(3)
    return out


def density_uncertainty(temperature_c: float, half_width_c: float, salinity_g_kg: float) -> float:
    """u(ρ) from the water temperature's tolerance ±a (rectangular): |dρ/dT|·a/√3, at the
    water's salinity (g/kg)."""
    if half_width_c <= 0:
        return 0.0
    u_t = half_width_c / math.sqrt(3)
    low = water_properties(max(temperature_c - u_t, 0.0), salinity_g_kg).density
    high = water_properties(min(temperature_c + u_t, 40.0), salinity_g_kg).density
    return abs(high - low) / 2


def theory_document(
    records: Sequence[RunInfo],
    result: dict[str, Any],
    repeats: RepeatAnalysis | None,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """{"theory": …} of ``result`` (its fitted runs' ``records`` give the rig file and the
    water): None (with the reason) when the vehicle file or its hull is missing."""
    axis, budget = result.get("axis"), result.get("budget")
    if budget is None or axis not in ("surge", "yaw"):
        return {"theory": None}
    rig = rig_of_runs(records)
    if rig is None:
        return {"theory": {"missing": "the runs carry no rig file (imported data)"}}
    try:
        vehicle = find_vehicle(rig.vehicle.name.lower())
    except VehicleNotFound as err:
        return {"theory": {"missing": str(err)}}
    if vehicle.hull is None:
        return {"theory": {"missing": f"vehicle {vehicle.name!r} declares no [hull]"}}
    temp, salinity, source = water_of_runs(records)
    try:
        water = water_properties(temp, salinity)
    except WaterError as err:  # a tank the formulas do not cover (recorded at 45 °C)
        return {
            "theory": {"missing": f"the runs' water ({source}) is outside the water model: {err}"}
        }
    hull = vehicle.hull
    tol = vehicle_tolerances(vehicle_files().get(rig.vehicle.name.lower()))
    predicted = predict_added_mass(hull, water.density).added_mass.values
    hull_scale = HullScale(
        length_m=hull.length_m,
        volume_m3=hull.displaced_volume_m3 or hull.primitive_volume_m3,
        reference_area_m2=hull.reference_area_m2 or hull.frontal_area_m2,
        body_inertia=vehicle.mass_kg if axis == "surge" else vehicle.inertia_kg_m2[2],
        predicted_added=predicted.get(axis),
        u_body=tol.get("mass_kg" if axis == "surge" else "yaw_inertia_kg_m2", 0.0),
        u_volume=tol.get("displaced_volume_m3", 0.0),
        u_length=tol.get("length_m", 0.0),
        u_density=density_uncertainty(temp, budget.get("tolerances", {}).get(TEMP, 0.0), salinity),
    )
    coefficients = {
        n: (c["value"], c["combined_standard_uncertainty"], c["effective_dof"])
        for n, c in budget["coefficients"].items()
        if n in ("inertia", "quadratic_damping")
    }
    conditions = repeats.conditions if repeats is not None else ()
    speeds = {rid: s for c in conditions for rid, s in zip(c.run_ids, c.values, strict=True)}
    doc = measured_beside_theory(axis, coefficients, speeds, water, hull_scale, rig.rig.g)
    doc["water"]["source"] = source
    doc["vehicle"] = vehicle.name
    if report_dir is not None and (Path(report_dir) / "report.md").exists():
        with (Path(report_dir) / "report.md").open("a", encoding="utf-8") as f:
            f.write("\n" + theory_markdown(doc))
    return {"theory": doc}
