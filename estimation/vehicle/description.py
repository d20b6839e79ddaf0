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

The TOML file is read by ``estimation.vehicle.vehicle_file``; identified per-axis models
are plugged in by ``estimation.vehicle.apply_estimates``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from functools import partial
from types import MappingProxyType
from typing import Any, TypeGuard

from estimation.theory.hull import Hull

DOFS: tuple[str, ...] = ("surge", "sway", "heave", "roll", "pitch", "yaw")
COEFFICIENT_KINDS: tuple[str, ...] = ("added_mass", "linear_damping", "quadratic_damping")
COEFFICIENT_NAMES: tuple[str, ...] = tuple(f"{k}.{d}" for k in COEFFICIENT_KINDS for d in DOFS)
#: Frames a vehicle file may be written in; vectors are multiplied by the sign triple.
FRAMES: dict[str, tuple[float, float, float]] = {
    "x-forward-y-starboard-z-down": (1.0, 1.0, 1.0),
    "x-forward-y-port-z-up": (1.0, -1.0, -1.0),
}
#: How far from 1 a direction's length may be.
UNIT_TOLERANCE = 1e-3
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

    def __reduce__(self) -> tuple[partial[Vehicle6], tuple[()]]:
        """Pickled (for the analysis worker process) with ``sigma`` as a plain dict: a
        read-only mapping does not pickle."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        return partial(type(self), **values | {"sigma": dict(self.sigma)}), ()

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
                    vehicle_source(self),
                    "coefficient",
                    name,
                    "one of " + ", ".join(COEFFICIENT_NAMES),
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
        i = dof_index(self, axis)
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
        return self.rigid_body_inertia(axis) + self.added_mass[dof_index(self, axis)]


def vehicle_source(vehicle: Vehicle6) -> str:
    """The vehicle as error messages name it: its file, else its name."""
    return vehicle.source or f"vehicle {vehicle.name!r}"


def dof_index(vehicle: Vehicle6, axis: str) -> int:
    """The position of ``axis`` in ``DOFS`` (VehicleError naming the vehicle if none)."""
    if axis not in DOFS:
        raise VehicleError(vehicle_source(vehicle), "axis", axis, "one of " + ", ".join(DOFS))
    return DOFS.index(axis)


def is_finite(x: object) -> TypeGuard[float]:
    """A finite int or float (not a bool)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _validate(v: Vehicle6) -> None:
    src = vehicle_source(v)

    def check(name: str, value: object, ok: bool, allowed: str) -> None:
        if not ok:
            raise VehicleError(src, name, value, allowed)

    if not isinstance(v.name, str) or not v.name.strip():
        raise VehicleError(src, "name", v.name, "a non-empty string")
    check("mass_kg", v.mass_kg, is_finite(v.mass_kg) and 0 < v.mass_kg <= 1e6, "0 < m ≤ 1e6 kg")
    check("g", v.g, is_finite(v.g) and 0 < v.g <= 30, "0 < g ≤ 30 m/s²")
    check(
        "buoyancy_n",
        v.buoyancy_n,
        is_finite(v.buoyancy_n) and 0 <= v.buoyancy_n <= 1e8,
        "0 ≤ B ≤ 1e8 N",
    )
    for fname in ("inertia_kg_m2", "cg_m", "cb_m"):
        vec = getattr(v, fname)
        check(fname, vec, isinstance(vec, tuple) and len(vec) == 3, "3 numbers")
    for i, axis in enumerate("xyz"):
        val = v.inertia_kg_m2[i]
        check(f"inertia_kg_m2.{axis}", val, is_finite(val) and 0 < val <= 1e6, "0 < I ≤ 1e6 kg·m²")
        for fname in ("cg_m", "cb_m"):
            val = getattr(v, fname)[i]
            check(
                f"{fname}.{axis}",
                val,
                is_finite(val) and abs(val) <= _MAX_POSITION_M,
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
            check(f"{kind}.{dof}", val, is_finite(val) and 0 <= val <= 1e7, "0 ≤ value ≤ 1e7")
    for name, val in v.sigma.items():
        check("sigma", name, name in COEFFICIENT_NAMES, "coefficient names")
        check(f"sigma.{name}", val, is_finite(val) and val >= 0, "≥ 0")
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
            is_finite(t.gain_n_per_command) and 0 < t.gain_n_per_command <= 1e6,
            "0 < gain ≤ 1e6 N per unit command",
        )
        check(
            f"{where}.max_command",
            t.max_command,
            is_finite(t.max_command) and 0 < t.max_command <= 1e6,
            "0 < max_command ≤ 1e6",
        )
        check(
            f"{where}.position_m",
            t.position_m,
            len(t.position_m) == 3
            and all(is_finite(x) and abs(x) <= _MAX_POSITION_M for x in t.position_m),
            f"3 finite numbers, each |x| ≤ {_MAX_POSITION_M:g} m",
        )
        norm = math.sqrt(sum(x * x for x in t.direction)) if len(t.direction) == 3 else 0.0
        check(
            f"{where}.direction",
            t.direction,
            all(is_finite(x) for x in t.direction) and abs(norm - 1) <= UNIT_TOLERANCE,
            "a unit vector (3 numbers, |d| = 1)",
        )


def checked_number(value: Any, source: str, path: str) -> float:
    """``value`` as a float; VehicleError naming ``source`` and ``path`` if not finite."""
    if not is_finite(value):
        raise VehicleError(source, path, value, "a finite number")
    return float(value)
