"""A 6-DOF vehicle description in Fossen's form: rigid body, diagonal added mass and
damping, weight and buoyancy, thrusters and, optionally, the hull as a primitive (``[hull]``,
parsed by ``estimation.theory.hull``). Loaded from a TOML file (format in docs/sixdof.md).

Internal frame (always): Fossen's body frame, origin at the body reference point (the
fixtures put it at the CG), **x forward, y starboard, z down**. A file may be written in
another right-handed frame (``frame = "x-forward-y-port-z-up"``, seed 002's); the loader
turns its vectors (thruster positions and directions, CG, CB) into the internal frame.

Coefficients are positive numbers: ``added_mass.<dof>`` = −X_u̇ … −N_ṙ (kg or kg·m²),
``linear_damping.<dof>`` (N·s/m or N·m·s/rad), ``quadratic_damping.<dof>``
(N·s²/m² or N·m·s²/rad²), so that D(ν)ν = (K_L + K_Q |ν|) ν per DOF.

One module because the vehicle file's schema, its parsing and its validation name the same
fields and frames; the error messages quote them, and split modules would repeat the field
table.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any, TypeGuard

from estimation.theory.hull import Hull, HullError, parse_hull

DOFS: tuple[str, ...] = ("surge", "sway", "heave", "roll", "pitch", "yaw")
COEFFICIENT_KINDS: tuple[str, ...] = ("added_mass", "linear_damping", "quadratic_damping")
COEFFICIENT_NAMES: tuple[str, ...] = tuple(f"{k}.{d}" for k in COEFFICIENT_KINDS for d in DOFS)
#: Frames a vehicle file may be written in; vectors are multiplied by the sign triple.
FRAMES: dict[str, tuple[float, float, float]] = {
    "x-forward-y-starboard-z-down": (1.0, 1.0, 1.0),
    "x-forward-y-port-z-up": (1.0, -1.0, -1.0),
}
_UNIT_TOLERANCE = 1e-3
_MAX_POSITION_M = 100.0


class VehicleError(ValueError):
    """A vehicle description that cannot be used: names the source, field, value, range."""

    def __init__(self, source: str, field_name: str, value: object, allowed: str) -> None:
        self.source, self.field, self.value, self.allowed = source, field_name, value, allowed
        super().__init__(f"{source}: {field_name}: got {value!r}, allowed: {allowed}")


@dataclass(frozen=True)
class Thruster:
    """One thruster: force ``gain_n_per_command · u`` along ``direction`` at ``position_m``
    (internal body frame, m, relative to the body origin), |u| ≤ ``max_command``."""

    name: str
    position_m: tuple[float, float, float]
    direction: tuple[float, float, float]
    gain_n_per_command: float
    max_command: float = 1.0


@dataclass(frozen=True)
class Vehicle6:
    """Everything the 6-DOF equations need; validated on construction (VehicleError).

    ``inertia_kg_m2`` is the body's (Ixx, Iyy, Izz) about the CG (products of inertia
    zero); ``cg_m``/``cb_m`` are relative to the body origin; ``buoyancy_n`` = ρ g V;
    the three coefficient tuples are ordered as ``DOFS``; ``sigma`` holds 1σ by
    coefficient name (``"added_mass.surge"`` …) where known.
    """

    name: str
    mass_kg: float
    inertia_kg_m2: tuple[float, float, float]
    cg_m: tuple[float, float, float]
    cb_m: tuple[float, float, float]
    buoyancy_n: float
    g: float
    added_mass: tuple[float, ...]
    linear_damping: tuple[float, ...]
    quadratic_damping: tuple[float, ...]
    thrusters: tuple[Thruster, ...]
    sigma: Mapping[str, float] = field(default_factory=dict, hash=False)
    #: Where the description came from (a file path), for error messages.
    source: str = field(default="", compare=False)
    #: Free text: where each number comes from.
    notes: str = field(default="", compare=False)
    #: The hull as a primitive (optional ``[hull]`` table) for predicted added mass.
    hull: Hull | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "sigma", MappingProxyType(dict(self.sigma)))
        _validate(self)

    @property
    def weight_n(self) -> float:
        """W = m g, N."""
        return self.mass_kg * self.g

    def coefficients(self) -> dict[str, float]:
        """All 18 coefficients by name, e.g. ``{"added_mass.surge": 59.04, …}``."""
        return {
            f"{kind}.{dof}": float(getattr(self, kind)[i])
            for kind in COEFFICIENT_KINDS
            for i, dof in enumerate(DOFS)
        }

    def with_coefficients(self, changes: Mapping[str, float]) -> Vehicle6:
        """A copy with some coefficients replaced (ValueError naming an unknown name)."""
        values = {kind: list(getattr(self, kind)) for kind in COEFFICIENT_KINDS}
        for name, value in changes.items():
            if name not in COEFFICIENT_NAMES:
                raise VehicleError(
                    _where(self), "coefficient", name, "one of " + ", ".join(COEFFICIENT_NAMES)
                )
            kind, dof = name.split(".")
            values[kind][DOFS.index(dof)] = float(value)
        return replace(self, **{k: tuple(v) for k, v in values.items()})  # type: ignore[arg-type]

    def body_inertia_about_origin(self) -> tuple[float, float, float]:
        """Diagonal of the body inertia about the body origin (parallel-axis theorem)."""
        xg, yg, zg = self.cg_m
        m = self.mass_kg
        ixx, iyy, izz = self.inertia_kg_m2
        return (ixx + m * (yg**2 + zg**2), iyy + m * (xg**2 + zg**2), izz + m * (xg**2 + yg**2))

    def rigid_body_inertia(self, axis: str) -> float:
        """Body mass (surge/sway/heave, kg) or body inertia about the origin (kg·m²)."""
        i = _dof_index(self, axis)
        return self.mass_kg if i < 3 else self.body_inertia_about_origin()[i - 3]

    def to_json(self) -> dict[str, Any]:
        """Parameters, coefficients (by name), σ and thrusters, in the internal frame."""
        return {
            "name": self.name,
            "frame": "x-forward-y-starboard-z-down",
            "mass_kg": self.mass_kg,
            "inertia_kg_m2": list(self.inertia_kg_m2),
            "cg_m": list(self.cg_m),
            "cb_m": list(self.cb_m),
            "weight_n": self.weight_n,
            "buoyancy_n": self.buoyancy_n,
            "g": self.g,
            "coefficients": self.coefficients(),
            "total_inertia": {dof: self.total_inertia(dof) for dof in DOFS},
            "sigma": dict(self.sigma),
            "thrusters": [
                {
                    "name": t.name,
                    "position_m": list(t.position_m),
                    "direction": list(t.direction),
                    "gain_n_per_command": t.gain_n_per_command,
                    "max_command": t.max_command,
                }
                for t in self.thrusters
            ],
            "notes": self.notes,
            "hull": self.hull.to_json() if self.hull is not None else None,
        }

    def total_inertia(self, axis: str) -> float:
        """Rigid-body plus added mass/inertia on one axis (the per-axis model's m + m_a)."""
        return self.rigid_body_inertia(axis) + self.added_mass[_dof_index(self, axis)]


def _where(vehicle: Vehicle6) -> str:
    return vehicle.source or f"vehicle {vehicle.name!r}"


def _dof_index(vehicle: Vehicle6, axis: str) -> int:
    if axis not in DOFS:
        raise VehicleError(_where(vehicle), "axis", axis, "one of " + ", ".join(DOFS))
    return DOFS.index(axis)


def _finite(x: object) -> TypeGuard[float]:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _validate(v: Vehicle6) -> None:
    src = _where(v)

    def check(name: str, value: object, ok: bool, allowed: str) -> None:
        if not ok:
            raise VehicleError(src, name, value, allowed)

    if not isinstance(v.name, str) or not v.name.strip():
        raise VehicleError(src, "name", v.name, "a non-empty string")
    check("mass_kg", v.mass_kg, _finite(v.mass_kg) and 0 < v.mass_kg <= 1e6, "0 < m ≤ 1e6 kg")
    check("g", v.g, _finite(v.g) and 0 < v.g <= 30, "0 < g ≤ 30 m/s²")
    check(
        "buoyancy_n",
        v.buoyancy_n,
        _finite(v.buoyancy_n) and 0 <= v.buoyancy_n <= 1e8,
        "0 ≤ B ≤ 1e8 N",
    )
    for fname in ("inertia_kg_m2", "cg_m", "cb_m"):
        vec = getattr(v, fname)
        check(fname, vec, isinstance(vec, tuple) and len(vec) == 3, "3 numbers")
    for i, axis in enumerate("xyz"):
        val = v.inertia_kg_m2[i]
        check(f"inertia_kg_m2.{axis}", val, _finite(val) and 0 < val <= 1e6, "0 < I ≤ 1e6 kg·m²")
        for fname in ("cg_m", "cb_m"):
            val = getattr(v, fname)[i]
            check(
                f"{fname}.{axis}",
                val,
                _finite(val) and abs(val) <= _MAX_POSITION_M,
                f"|value| ≤ {_MAX_POSITION_M:g} m",
            )
    ixx, iyy, izz = v.inertia_kg_m2
    for name, a, b, c in (("x", ixx, iyy, izz), ("y", iyy, ixx, izz), ("z", izz, ixx, iyy)):
        # A rigid body's principal inertias obey the triangle inequality (1 % slack).
        check(
            f"inertia_kg_m2.{name}",
            a,
            a <= 1.01 * (b + c),
            f"≤ the sum of the other two ({b + c:g} kg·m², rigid-body triangle inequality)",
        )
    for kind in COEFFICIENT_KINDS:
        values = getattr(v, kind)
        check(kind, values, isinstance(values, tuple) and len(values) == 6, "6 numbers")
        for dof, val in zip(DOFS, values, strict=True):
            check(f"{kind}.{dof}", val, _finite(val) and 0 <= val <= 1e7, "0 ≤ value ≤ 1e7")
    for name, val in v.sigma.items():
        check("sigma", name, name in COEFFICIENT_NAMES, "coefficient names")
        check(f"sigma.{name}", val, _finite(val) and val >= 0, "≥ 0")
    names = [t.name for t in v.thrusters]
    for i, t in enumerate(v.thrusters):
        where = f"thrusters[{i}]"
        check(
            f"{where}.name", t.name, isinstance(t.name, str) and bool(t.name), "a non-empty string"
        )
        check(f"{where}.name", t.name, names.count(t.name) == 1, "unique thruster names")
        check(
            f"{where}.gain_n_per_command",
            t.gain_n_per_command,
            _finite(t.gain_n_per_command) and 0 < t.gain_n_per_command <= 1e6,
            "0 < gain ≤ 1e6 N per unit command",
        )
        check(
            f"{where}.max_command",
            t.max_command,
            _finite(t.max_command) and 0 < t.max_command <= 1e6,
            "0 < max_command ≤ 1e6",
        )
        check(
            f"{where}.position_m",
            t.position_m,
            len(t.position_m) == 3
            and all(_finite(x) and abs(x) <= _MAX_POSITION_M for x in t.position_m),
            f"3 finite numbers, each |x| ≤ {_MAX_POSITION_M:g} m",
        )
        norm = math.sqrt(sum(x * x for x in t.direction)) if len(t.direction) == 3 else 0.0
        check(
            f"{where}.direction",
            t.direction,
            all(_finite(x) for x in t.direction) and abs(norm - 1) <= _UNIT_TOLERANCE,
            "a unit vector (3 numbers, |d| = 1)",
        )


# ---- the TOML file ------------------------------------------------------------------


def _get(table: Mapping[str, Any], key: str, source: str, path: str, default: Any = ...) -> Any:
    if key not in table:
        if default is ...:
            raise VehicleError(source, path, None, "required")
        return default
    return table[key]


def _number(value: Any, source: str, path: str) -> float:
    if not _finite(value):
        raise VehicleError(source, path, value, "a finite number")
    return float(value)


def _vector(value: Any, source: str, path: str) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise VehicleError(source, path, value, "a list of 3 numbers")
    x, y, z = (_number(c, source, f"{path}[{i}]") for i, c in enumerate(value))
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
        _number(_get(table, d, source, f"{kind}.{d}"), source, f"{kind}.{d}") for d in DOFS
    )


def _direction(raw: Mapping[str, Any], source: str, path: str) -> tuple[float, float, float]:
    """``direction = [x, y, z]`` (unit), or ``azimuth_deg`` (in the x–y plane from +x
    towards +y) with ``elevation_deg`` (towards +z of the file's frame)."""
    if "direction" in raw:
        d = _vector(raw["direction"], source, f"{path}.direction")
        norm = math.sqrt(sum(c * c for c in d))
        if abs(norm - 1) > _UNIT_TOLERANCE:
            raise VehicleError(
                source, f"{path}.direction", list(d), "a unit vector (|d| = 1 ± 0.001)"
            )
        x, y, z = (c / norm for c in d)
        return (x, y, z)
    if "azimuth_deg" not in raw:
        raise VehicleError(
            source, f"{path}.direction", None, "direction = [x, y, z] or azimuth_deg"
        )
    az = math.radians(_number(raw["azimuth_deg"], source, f"{path}.azimuth_deg"))
    el = math.radians(_number(raw.get("elevation_deg", 0.0), source, f"{path}.elevation_deg"))
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
    g = _number(_get(v, "g", source, "vehicle.g", 9.81), source, "vehicle.g")
    if "buoyancy_n" in v:
        buoyancy = _number(v["buoyancy_n"], source, "vehicle.buoyancy_n")
    else:
        volume = _number(
            _get(v, "displaced_volume_m3", source, "vehicle.buoyancy_n or displaced_volume_m3"),
            source,
            "vehicle.displaced_volume_m3",
        )
        rho = _number(
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
                gain_n_per_command=_number(
                    _get(raw, "gain_n_per_command", source, f"{path}.gain_n_per_command"),
                    source,
                    f"{path}.gain_n_per_command",
                ),
                max_command=_number(raw.get("max_command", 1.0), source, f"{path}.max_command"),
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
        mass_kg=_number(_get(v, "mass_kg", source, "vehicle.mass_kg"), source, "vehicle.mass_kg"),
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
        sigma={str(k): _number(s, source, f"sigma.{k}") for k, s in sigma.items()},
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


_ESTIMATE_SIGMA = {
    "inertia": "added_mass",
    "linear_damping": "linear_damping",
    "quadratic_damping": "quadratic_damping",
}


def apply_estimate(
    vehicle: Vehicle6,
    axis: str,
    inertia: float,
    linear: float,
    quadratic: float,
    sigma: Mapping[str, float] | None = None,
) -> Vehicle6:
    """Plug an identified per-axis model ``I ν̇ + K_L ν + K_Q |ν| ν = τ`` into the vehicle.

    ``inertia`` is the total (body + added): added_mass.<axis> = inertia − body mass
    (surge/sway/heave) or − body inertia about the origin (roll/pitch/yaw); a negative
    result is an error naming it. ``sigma`` may be keyed ``inertia``/``linear_damping``/
    ``quadratic_damping`` (σ of the added mass is σ of the total inertia: the body's is
    taken as exact) or by full coefficient name.
    """
    i = _dof_index(vehicle, axis)
    body = vehicle.rigid_body_inertia(axis)
    where = _where(vehicle)
    inertia = _number(inertia, where, f"{axis} inertia")
    added = inertia - body
    if added < 0:
        unit = "kg" if i < 3 else "kg·m²"
        raise VehicleError(
            where,
            f"added_mass.{axis}",
            added,
            f"≥ 0: the identified inertia {inertia:g} {unit} is below the body's {body:g} {unit}",
        )
    changed = vehicle.with_coefficients(
        {
            f"added_mass.{axis}": added,
            f"linear_damping.{axis}": _number(linear, where, f"linear_damping.{axis}"),
            f"quadratic_damping.{axis}": _number(quadratic, where, f"quadratic_damping.{axis}"),
        }
    )
    if not sigma:
        return changed
    new_sigma = dict(vehicle.sigma)
    for key, value in sigma.items():
        name = f"{_ESTIMATE_SIGMA[key]}.{axis}" if key in _ESTIMATE_SIGMA else key
        new_sigma[name] = value
    return replace(changed, sigma=new_sigma)


def apply_result_json(
    vehicle: Vehicle6, doc: Mapping[str, Any], source: str = "result"
) -> Vehicle6:
    """Plug a stored per-axis estimation result (``EstimationResult.to_json()``: ``axis``
    and ``coefficients`` {inertia, linear_damping, quadratic_damping: {value, std}}) into
    the vehicle with :func:`apply_estimate`; σ comes along where the result has one.

    A pendulum free-decay result (``"analysis": "pendulum"``) gives the swing axis's
    ``added_mass`` and ``linear_damping`` (and ``quadratic_damping`` when its effect search
    found it; otherwise the vehicle's value stays)."""
    axis = doc.get("axis") if isinstance(doc, Mapping) else None
    if axis not in DOFS:
        raise VehicleError(source, "axis", axis, "one of " + ", ".join(DOFS))
    coefficients = doc.get("coefficients")
    if not isinstance(coefficients, Mapping):
        raise VehicleError(source, "coefficients", coefficients, "a table of {value, std}")
    pendulum = doc.get("analysis") == "pendulum"
    if pendulum:
        coefficients = dict(coefficients)
        added = coefficients.pop("added_mass", None)
        if isinstance(added, Mapping) and _finite(added.get("value")):
            body = vehicle.rigid_body_inertia(axis)
            coefficients["inertia"] = {"value": body + added["value"], "std": added.get("std")}
        coefficients.setdefault(
            "quadratic_damping", {"value": vehicle.coefficients()[f"quadratic_damping.{axis}"]}
        )
    values: dict[str, float] = {}
    sigma: dict[str, float] = {}
    for key in ("inertia", "linear_damping", "quadratic_damping"):
        entry = coefficients.get(key)
        value = entry.get("value") if isinstance(entry, Mapping) else None
        if not _finite(value):
            raise VehicleError(source, f"coefficients.{key}.value", value, "a finite number")
        values[key] = float(value)
        std = entry.get("std")  # type: ignore[union-attr]
        if _finite(std) and std >= 0:
            sigma[key] = float(std)
    try:
        return apply_estimate(
            vehicle,
            axis,
            values["inertia"],
            values["linear_damping"],
            values["quadratic_damping"],
            sigma,
        )
    except VehicleError as err:
        raise VehicleError(source, err.field, err.value, err.allowed) from None
