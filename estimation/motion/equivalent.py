"""Equivalent linear damping of a fitted equation, per amplitude of swing.

    B_e(a) = Σ_j θ_j·b_j(a, ω₀),   b_j = −∮ φ_j(x, ẋ)·ẋ dt / (π·a²·ω₀)  for x = a·cos ω₀t

(``Term.equivalent_damping``: B₁ + 8/(3π)·ω₀·a·B₂ + 3/4·ω₀²·a²·B₃ + 4·F_c/(π·ω₀·a)): the
linear damping that takes the same energy out of one cycle at amplitude a as every kept
and known term together. It is how roll damping is compared across models (the KVLCC2
authors' Be5 is B_e at 5°): two fits that share the energy per cycle differently between
B₁, B₂ and dry friction agree on B_e over the amplitudes the record covers. σ from the
fit's covariance (B_e is linear in θ); ω₀ = 2π/T₀ from the fitted period is taken as
exact (its relative σ is half the inertia's, ≈ 0.1 % on a decay). Known terms add their
value without σ.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.motion.output_error_fit import MotionFit
from estimation.motion.terms import LIBRARY
from estimation.report_numbers import Coefficient, finite_or_none

AMPLITUDES = 5  # amplitudes reported, geometric from the smallest swing to the largest


@dataclass(frozen=True)
class EquivalentDamping(Coefficient):
    """B_e at ``amplitude`` (m or rad), with σ (None: a term it sums is not identified)."""

    amplitude: float

    def to_json(self) -> dict[str, Any]:
        """{amplitude, value, std, unit}."""
        return {"amplitude": finite_or_none(self.amplitude)} | super().to_json()


def equivalent_damping(
    fit: MotionFit,
    known: Mapping[str, float],
    dof: str,
    amplitude: float,
    omega: float,
    weights: Mapping[str, float] | None = None,
) -> EquivalentDamping:
    """B_e of ``fit`` plus its ``known`` terms at ``amplitude`` and ``omega`` (rad/s); an
    identified coefficient counts with its record's ``weight`` (a pendulum's vehicle term
    at lever arm l: B_e is then the pivot's, in N·m·s/rad)."""

    formed: dict[str, float] = {}  # a term both fitted and known (a pivot's damping): once

    def per_unit_of(name: str) -> float:
        if name not in formed:
            term = LIBRARY.get(name)
            formed[name] = term.equivalent_damping(amplitude, omega) if term else 0.0
        return formed[name]

    w = weights or {}
    per_unit = np.array([per_unit_of(n) * float(w.get(n, 1.0)) for n in fit.names])
    value = float(per_unit @ fit.values) + sum(v * per_unit_of(n) for n, v in known.items())
    used = np.nonzero(per_unit)[0]
    std = fit.std[used]
    sigma = None
    if np.all(np.isfinite(std)):
        cov = np.outer(std, std) * fit.correlation[np.ix_(used, used)]
        sigma = float(np.sqrt(max(per_unit[used] @ cov @ per_unit[used], 0.0)))
    unit = LIBRARY["linear_damping"].unit(dof)
    return EquivalentDamping(value, sigma, unit, amplitude=amplitude)


def swing_range(fit: MotionFit, period: float, times: Sequence[np.ndarray]) -> tuple[float, float]:
    """The smallest and largest swing of the fitted motion (m or rad): the largest |ξ| over
    the last period of each record's window, and over the whole window."""
    small, large = np.inf, 0.0
    for t, xi in zip(times, fit.displacements, strict=True):
        t, xi = np.asarray(t, dtype=float), np.abs(np.asarray(xi, dtype=float))
        small = min(small, float(np.max(xi[t >= t[-1] - period], initial=0.0)))
        large = max(large, float(np.max(xi, initial=0.0)))
    return small, large


def damping_over_swings(
    fit: MotionFit,
    known: Mapping[str, float],
    dof: str,
    period: float | None,
    times: Sequence[np.ndarray],
    weights: Mapping[str, float] | None = None,
) -> tuple[EquivalentDamping, ...]:
    """B_e at ``AMPLITUDES`` amplitudes spanning the swings the records cover (none when
    the motion has no period); ``weights`` as ``equivalent_damping``'s."""
    if period is None or not np.isfinite(period) or period <= 0:
        return ()
    small, large = swing_range(fit, period, times)
    if not 0 < small <= large:
        return ()
    omega = 2 * np.pi / period
    return tuple(
        equivalent_damping(fit, known, dof, float(a), omega, weights)
        for a in np.geomspace(small, large, AMPLITUDES)
    )
