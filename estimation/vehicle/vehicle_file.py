"""The vehicle TOML file (format in docs/sixdof.md) read into a :class:`Vehicle6`: every
field checked by name, vectors turned from the file's frame (``FRAMES``) into the internal
one, the hull parsed by ``estimation.theory.hull``."""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from estimation.theory.hull import HullError, parse_hull
from estimation.vehicle.description import (
    COEFFICIENT_KINDS,
    DOFS,
    FRAMES,
    UNIT_TOLERANCE,
    Thruster,
    Vehicle6,
    VehicleError,
    checked_number,
)


def _get(table: Mapping[str, Any], key: str, source: str, path: str, default: Any = ...) -> Any:
    if key not in table:
        if default is ...:
            raise VehicleError(source, path, None, "required")
        return default
    return table[key]


def _vector(value: Any, source: str, path: str) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise VehicleError(source, path, value, "a list of 3 numbers")
    x, y, z = (checked_number(c, source, f"{path}[{i}]") for i, c in enumerate(value))
    return (x, y, z)


def _in_frame(
    vec: tuple[float, float, float], signs: tuple[float, float, float]
) -> tuple[float, float, float]:
    """A file-frame vector in the internal frame (+ 0.0 turns −0.0 into 0.0)."""
    return (signs[0] * vec[0] + 0.0, signs[1] * vec[1] + 0.0, signs[2] * vec[2] + 0.0)


def _per_dof(data: Mapping[str, Any], kind: str, source: str) -> tuple[float, ...]:
    table = _get(data, kind, source, f"[{kind}]")
    if not isinstance(table, dict):
        raise VehicleError(source, f"[{kind}]", table, "a table with " + ", ".join(DOFS))
    unknown = sorted(set(table) - set(DOFS))
    if unknown:
        raise VehicleError(
            source, f"{kind}.{unknown[0]}", table[unknown[0]], "keys " + ", ".join(DOFS)
        )
    return tuple(
        checked_number(_get(table, d, source, f"{kind}.{d}"), source, f"{kind}.{d}") for d in DOFS
    )


def _direction(raw: Mapping[str, Any], source: str, path: str) -> tuple[float, float, float]:
    """``direction = [x, y, z]`` (unit), or ``azimuth_deg`` (in the x–y plane from +x
    towards +y) with ``elevation_deg`` (towards +z of the file's frame)."""
    if "direction" in raw:
        d = _vector(raw["direction"], source, f"{path}.direction")
        norm = math.sqrt(sum(c * c for c in d))
        if abs(norm - 1) > UNIT_TOLERANCE:
            raise VehicleError(
                source, f"{path}.direction", list(d), "a unit vector (|d| = 1 ± 0.001)"
            )
        x, y, z = (c / norm for c in d)
        return (x, y, z)
    if "azimuth_deg" not in raw:
        raise VehicleError(
            source, f"{path}.direction", None, "direction = [x, y, z] or azimuth_deg"
        )
    az = math.radians(checked_number(raw["azimuth_deg"], source, f"{path}.azimuth_deg"))
    el = math.radians(
        checked_number(raw.get("elevation_deg", 0.0), source, f"{path}.elevation_deg")
    )
    return (math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el))


#: ``[tolerances]`` (±a of mass_kg, yaw_inertia_kg_m2, displaced_volume_m3, length_m) is read by
#: the uncertainty budget of the added mass (``api.core.theory_job``), not by the 6-DOF model.
_TABLES = ("vehicle", *COEFFICIENT_KINDS, "sigma", "thrusters", "hull", "tolerances")
_VEHICLE_KEYS = (
    "name",
    "frame",
    "mass_kg",
    "g",
    "buoyancy_n",
    "displaced_volume_m3",
    "water_density_kg_m3",
    "inertia_kg_m2",
    "cg_m",
    "cb_m",
    "notes",
)
_THRUSTER_KEYS = (
    "name",
    "position_m",
    "direction",
    "azimuth_deg",
    "elevation_deg",
    "gain_n_per_command",
    "max_command",
)


def _known_keys(table: Mapping[str, Any], known: tuple[str, ...], source: str, prefix: str) -> None:
    """A misspelt key would otherwise fall back silently to a default."""
    for key in table:
        if key not in known:
            raise VehicleError(source, f"{prefix}{key}", table[key], "keys " + ", ".join(known))


def parse_vehicle(data: dict, source: str) -> Vehicle6:
    """A ``Vehicle6`` from a parsed vehicle file (``source`` names it in errors)."""
    _known_keys(data, _TABLES, source, "")
    v = _get(data, "vehicle", source, "[vehicle]")
    if not isinstance(v, dict):
        raise VehicleError(source, "[vehicle]", v, "a table")
    _known_keys(v, _VEHICLE_KEYS, source, "vehicle.")
    frame = _get(v, "frame", source, "vehicle.frame", "x-forward-y-starboard-z-down")
    if frame not in FRAMES:
        raise VehicleError(source, "vehicle.frame", frame, " or ".join(repr(f) for f in FRAMES))
    signs = FRAMES[frame]
    g = checked_number(_get(v, "g", source, "vehicle.g", 9.81), source, "vehicle.g")
    if "buoyancy_n" in v:
        buoyancy = checked_number(v["buoyancy_n"], source, "vehicle.buoyancy_n")
    else:
        volume = checked_number(
            _get(v, "displaced_volume_m3", source, "vehicle.buoyancy_n or displaced_volume_m3"),
            source,
            "vehicle.displaced_volume_m3",
        )
        rho = checked_number(
            _get(v, "water_density_kg_m3", source, "vehicle.water_density_kg_m3", 998.0),
            source,
            "vehicle.water_density_kg_m3",
        )
        buoyancy = rho * g * volume
    thrusters = []
    raw_thrusters = data.get("thrusters", [])
    if not isinstance(raw_thrusters, list):
        raise VehicleError(source, "[[thrusters]]", raw_thrusters, "an array of tables")
    for i, raw in enumerate(raw_thrusters):
        path = f"thrusters[{i}]"
        if not isinstance(raw, dict):
            raise VehicleError(source, path, raw, "a table ([[thrusters]])")
        _known_keys(raw, _THRUSTER_KEYS, source, f"{path}.")
        thrusters.append(
            Thruster(
                name=str(_get(raw, "name", source, f"{path}.name", str(i + 1))),
                position_m=_in_frame(
                    _vector(
                        _get(raw, "position_m", source, f"{path}.position_m"),
                        source,
                        f"{path}.position_m",
                    ),
                    signs,
                ),
                direction=_in_frame(_direction(raw, source, path), signs),
                gain_n_per_command=checked_number(
                    _get(raw, "gain_n_per_command", source, f"{path}.gain_n_per_command"),
                    source,
                    f"{path}.gain_n_per_command",
                ),
                max_command=checked_number(
                    raw.get("max_command", 1.0), source, f"{path}.max_command"
                ),
            )
        )
    hull = None
    if "hull" in data:
        try:
            hull = parse_hull(data["hull"])
        except HullError as err:
            raise VehicleError(source, err.field, err.value, err.allowed) from None
    sigma = data.get("sigma", {})
    if not isinstance(sigma, dict):
        raise VehicleError(source, "[sigma]", sigma, "a table of coefficient name = 1σ")
    return Vehicle6(
        name=str(_get(v, "name", source, "vehicle.name")),
        mass_kg=checked_number(
            _get(v, "mass_kg", source, "vehicle.mass_kg"), source, "vehicle.mass_kg"
        ),
        inertia_kg_m2=_vector(
            _get(v, "inertia_kg_m2", source, "vehicle.inertia_kg_m2"),
            source,
            "vehicle.inertia_kg_m2",
        ),
        cg_m=_in_frame(_vector(v.get("cg_m", [0, 0, 0]), source, "vehicle.cg_m"), signs),
        cb_m=_in_frame(_vector(v.get("cb_m", [0, 0, 0]), source, "vehicle.cb_m"), signs),
        buoyancy_n=buoyancy,
        g=g,
        added_mass=_per_dof(data, "added_mass", source),
        linear_damping=_per_dof(data, "linear_damping", source),
        quadratic_damping=_per_dof(data, "quadratic_damping", source),
        thrusters=tuple(thrusters),
        sigma={str(k): checked_number(s, source, f"sigma.{k}") for k, s in sigma.items()},
        source=source,
        notes=str(v.get("notes", "")),
        hull=hull,
    )


def load_vehicle(path: str | Path) -> Vehicle6:
    """Read and validate a vehicle TOML file (VehicleError naming the file on bad input)."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise VehicleError(str(path), "file", str(exc), "valid TOML") from exc
    except OSError as exc:
        raise VehicleError(str(path), "file", exc.strerror, "a readable file") from exc
    return parse_vehicle(data, str(path))
