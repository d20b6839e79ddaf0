"""Type B inputs of the measurement chain and how each one reaches the runs.

A weight-driven run's drive and declared inertia are computed from rig constants:
surge F = m_w·g, M_drive = m_w + J_p/r_p²; yaw τ = m_w·g·r_d, M_drive = m_w·r_d² + J_d;
the encoder turns counts into metres (radians) with a scale factor; a thruster-driven
run's drive comes from a load-cell calibration. Each constant is known only within a
declared tolerance ±a. ``perturbed(runs, chain, source, δ)`` returns the runs as the
estimator would have seen them had the constant been nominal + δ (one ``RunData`` field
changed per effect), so a re-fit gives ∂coefficient/∂input (``estimation.uncertainty.budget``).

Tolerances are half-widths of a rectangular distribution (a weight certified to ±a, a
radius machined to ±a): standard uncertainty u = a/√3 (GUM 4.3.7).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from estimation.data.run_arrays import RunData
from estimation.errors import FieldError


class ToleranceError(FieldError):
    """A declared tolerance that is not a non-negative finite number, or an unknown name."""


@dataclass(frozen=True)
class Chain:
    """The rig constants a weight-driven run's drive and inertia were computed with (SI)."""

    g: float  # m/s², the g the rig file turned hung masses into forces with
    pulley_radius_m: float | None = None
    pulley_inertia_kg_m2: float = 0.0
    drum_radius_m: float | None = None
    drum_inertia_kg_m2: float = 0.0


@dataclass(frozen=True)
class Source:
    """One declared Type B input: its unit, which axis it reaches, what it changes."""

    name: str
    unit: str
    axes: tuple[str, ...]
    meaning: str
    #: (runs, chain, δ) → the runs had the input been nominal + δ (δ in ``unit``).
    apply: Callable[[Sequence[RunData], Chain, float], list[RunData]]
    #: Each distinct hung weight is an independent input (one δ per weight).
    per_weight: bool = False


def _sign(run: RunData) -> float:
    return float(np.sign(np.mean(run.drive_at_samples()))) or 1.0


def _weight_runs(runs: Sequence[RunData]) -> list[bool]:
    return [r.is_constant_drive() and r.hung_mass_kg is not None for r in runs]


def _arm(run: RunData) -> float:
    """Force → drive factor: 1 for surge, the drum radius for yaw."""
    return 1.0 if run.axis == "surge" else float(run.drum_radius_m or 0.0)


def _hung_mass(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    out = []
    for r, weighted in zip(runs, _weight_runs(runs), strict=True):
        if weighted and r.hung_mass_kg is not None:
            drive = float(r.drive) + _sign(r) * delta * chain.g * _arm(r)
            r = replace(r, drive=drive, hung_mass_kg=r.hung_mass_kg + delta)
        out.append(r)
    return out


def _gravity(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    return [
        replace(r, drive=float(r.drive) + _sign(r) * (r.hung_mass_kg or 0.0) * delta * _arm(r))
        if weighted
        else r
        for r, weighted in zip(runs, _weight_runs(runs), strict=True)
    ]


def _pulley_inertia(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    if not chain.pulley_radius_m:
        return list(runs)
    extra = delta / chain.pulley_radius_m**2
    return [
        replace(r, drive_inertia=r.drive_inertia + extra) if w and r.axis == "surge" else r
        for r, w in zip(runs, _weight_runs(runs), strict=True)
    ]


def _pulley_radius(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    if not chain.pulley_radius_m:
        return list(runs)
    j, r0 = chain.pulley_inertia_kg_m2, chain.pulley_radius_m
    change = j / (r0 + delta) ** 2 - j / r0**2
    return [
        replace(r, drive_inertia=r.drive_inertia + change) if w and r.axis == "surge" else r
        for r, w in zip(runs, _weight_runs(runs), strict=True)
    ]


def _drum_radius(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    out = []
    for r, weighted in zip(runs, _weight_runs(runs), strict=True):
        if weighted and r.axis == "yaw" and r.drum_radius_m is not None:
            drive = float(r.drive) + _sign(r) * (r.hung_mass_kg or 0.0) * chain.g * delta
            r = replace(r, drive=drive, drum_radius_m=r.drum_radius_m + delta)
        out.append(r)
    return out


def _drum_inertia(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    return [
        replace(r, drive_inertia=r.drive_inertia + delta) if w and r.axis == "yaw" else r
        for r, w in zip(runs, _weight_runs(runs), strict=True)
    ]


def _position_scale(axis: str) -> Callable[[Sequence[RunData], Chain, float], list[RunData]]:
    def apply(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
        return [
            replace(r, position=np.asarray(r.position) * (1.0 + delta)) if r.axis == axis else r
            for r in runs
        ]

    return apply


def _thrust_scale(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    out = []
    for r in runs:
        if not r.is_constant_drive():
            draws = None if r.drive_draws is None else np.asarray(r.drive_draws) * (1 + delta)
            r = replace(r, drive=np.asarray(r.drive) * (1 + delta), drive_draws=draws)
        out.append(r)
    return out


def _no_effect(runs: Sequence[RunData], chain: Chain, delta: float) -> list[RunData]:
    return list(runs)


#: Every Type B input a rig file may declare, by its ``[tolerances]`` key.
SOURCES: dict[str, Source] = {
    s.name: s
    for s in (
        Source(
            "hung_mass_kg",
            "kg",
            ("surge", "yaw"),
            "each hung weight's mass (its force m·g and its own inertia)",
            _hung_mass,
            per_weight=True,
        ),
        Source("g_m_s2", "m/s²", ("surge", "yaw"), "local g (force = m·g)", _gravity),
        Source(
            "pulley_radius_m",
            "m",
            ("surge",),
            "tow pulley radius (its inertia acts as J/r²)",
            _pulley_radius,
        ),
        Source(
            "pulley_inertia_kg_m2",
            "kg·m²",
            ("surge",),
            "tow pulley inertia J (adds J/r² to the towed mass)",
            _pulley_inertia,
        ),
        Source(
            "spin_drum_radius_m",
            "m",
            ("yaw",),
            "spin drum radius (torque m·g·r, weight inertia m·r²)",
            _drum_radius,
        ),
        Source(
            "spin_drum_inertia_kg_m2", "kg·m²", ("yaw",), "spin drum inertia J_d", _drum_inertia
        ),
        Source(
            "encoder_scale_rel",
            "1",
            ("surge",),
            "tow encoder scale (metres per count, relative)",
            _position_scale("surge"),
        ),
        Source(
            "angle_scale_rel",
            "1",
            ("yaw",),
            "yaw encoder scale (radians per count, relative)",
            _position_scale("yaw"),
        ),
        Source(
            "thrust_calibration_rel",
            "1",
            ("surge", "yaw"),
            "load-cell / thrust calibration scale (relative) of thruster-driven runs",
            _thrust_scale,
        ),
        Source(
            "water_temperature_c",
            "°C",
            ("surge", "yaw"),
            "water temperature: enters ρ and ν (Re, Fr, dimensionless coefficients), "
            "not the dimensional coefficients",
            _no_effect,
        ),
    )
}


def check_tolerances(tolerances: Mapping[str, float]) -> dict[str, float]:
    """The declared half-widths, checked: known names, finite and ≥ 0 (else ToleranceError)."""
    out = {}
    for name, value in tolerances.items():
        if name not in SOURCES:
            raise ToleranceError(f"tolerances.{name}", name, ", ".join(SOURCES))
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ToleranceError(f"tolerances.{name}", value, "a number >= 0")
        if not math.isfinite(value) or value < 0:
            raise ToleranceError(f"tolerances.{name}", value, "a finite number >= 0")
        out[name] = float(value)
    return out


def weight_groups(runs: Sequence[RunData]) -> list[list[int]]:
    """Indices of the runs that hung the same weight (to the gram): one weight, one error."""
    groups: dict[float, list[int]] = {}
    for i, r in enumerate(runs):
        if r.is_constant_drive() and r.hung_mass_kg is not None:
            groups.setdefault(round(r.hung_mass_kg, 3), []).append(i)
    return [groups[k] for k in sorted(groups)]


def perturbed(
    runs: Sequence[RunData], chain: Chain, source: str, delta: float, only: Sequence[int] = ()
) -> list[RunData]:
    """The runs had input ``source`` been nominal + ``delta``; ``only``: the run indices a
    per-weight input reaches (one weight), all runs when empty."""
    changed = SOURCES[source].apply(runs, chain, delta)
    if not only:
        return changed
    return [changed[i] if i in only else r for i, r in enumerate(runs)]


def reaches(runs: Sequence[RunData], chain: Chain, source: str, delta: float) -> bool:
    """True when input ``source`` moved by ``delta`` changes any run the estimator sees."""
    for before, after in zip(runs, perturbed(runs, chain, source, delta), strict=True):
        if (
            before.hung_mass_kg != after.hung_mass_kg
            or before.drive_inertia != after.drive_inertia
            or before.drum_radius_m != after.drum_radius_m
            or not np.array_equal(before.drive, after.drive)
            or not np.array_equal(before.position, after.position)
        ):
            return True
    return False
