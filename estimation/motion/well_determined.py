"""What a record determines well, printed beside the raw coefficients.

The raw coefficients of a fit can be poorly determined one by one while a combination of
them is known closely: a settling sphere's K_L and K_Q trade against each other along one
steady force balance, yet the speed it settles at is read off the record's slope; a decay's
inertia and stiffness give its period, and its damping terms share the energy per cycle.

- **Terminal speed** at a constant drive τ (N or N·m), from the steady balance of every
  kept force term that depends on velocity alone,

      τ + Σ_j θ_j·φ_j(0, u∞) = 0,      ∂u∞/∂θ_j = φ_j(u∞) / (τ + Σ θ φ)'(u∞)·(−1),

  (none when a kept term depends on position or time: a spring holds the body, it does
  not settle at a speed). σ by the delta method from the fit's covariance
  (``FitStatistics.combination_std``): known even when the terms it combines are not
  identified one by one, as long as the data determine the combination (a settling sphere's
  K_L and K_Q trade along the steady balance that fixes its speed).
- **Drag at a tested speed** u (m/s or rad/s, the speed a run reached, taken as given):
  D(u) = −Σ_j θ_j·φ_j(0, u) over the kept terms that depend on velocity alone (N or N·m,
  signed like u: the force the motion meets); linear in θ, so σ_D² = gᵀ·C·g with
  g_j = −φ_j(0, u) and C the fit's covariance (exact: no linearisation; determined or not
  as the terminal speed).
- **Natural period** T₀ = 2π·√(M/k) with σ from the inertia's and stiffness's σ and their
  correlation (a known one exact), the **natural frequency** ω₀ = 2π/T₀ (σ_ω/ω₀ = σ_T/T₀),
  and the **damping ratio** ζ(a) = B_e(a)/(2·M·ω₀) at each swing amplitude a the
  equivalent damping is given at (``motion.equivalent``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.motion.equivalent import EquivalentDamping
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.records import Record, Setup, known_inertia_of, known_terms_of
from estimation.motion.terms import DOFS, LIBRARY, force_unit
from estimation.report_numbers import Coefficient
from estimation.stats.fit_statistics import FitStatistics

#: A speed search doubles its upper bracket at most this many times from the first guess.
MAX_DOUBLINGS = 60


@dataclass(frozen=True)
class Combination(Coefficient):
    """A well-determined combination of coefficients: what it is, value ± σ, unit."""

    name: str

    def to_json(self) -> dict[str, Any]:
        """{name, value, std, unit}."""
        return {"name": self.name} | super().to_json()


def terminal_speed(fit: FitStatistics, drive: float, dof: str) -> Combination | None:
    """The steady speed a constant ``drive`` reaches under ``fit``'s force terms (module
    doc), or None when the model has no steady speed (a position or time term is kept, no
    damping, or the drive does not overcome a dry friction)."""
    values = fit.values
    terms = [(i, LIBRARY[n]) for i, n in enumerate(fit.names) if n in LIBRARY]
    if drive == 0 or any(
        t.role == "time" or (t.role == "force" and t.x_power is not None) for _, t in terms
    ):
        return None
    used = [(i, t) for i, t in terms if t.role == "force" and t.v_power is not None]
    if not any(t.v_power and values[i] > 0 for i, t in used):
        return None
    way = float(np.sign(drive))
    # what every evaluation reads, looked up once (the root search evaluates ~20 times)
    zero, forces = np.zeros(1), [(values[i], t.phi) for i, t in used]

    def balance(u: float) -> float:  # drive + Σ θ φ along the drive's direction
        v = np.array([way * u])
        return way * (drive + sum(c * float(phi(zero, v)[0]) for c, phi in forces))

    tiny = 1e-12
    if balance(tiny) <= 0:
        return None
    high = 1e-3
    for _ in range(MAX_DOUBLINGS):
        if balance(high) < 0:
            break
        high *= 2.0
    else:
        return None
    from scipy.optimize import brentq  # here: the service imports this module's types

    u = brentq(balance, tiny, high, xtol=1e-15, rtol=1e-12)
    h = 1e-6 * u
    slope = (balance(u + h) - balance(u - h)) / (2 * h)
    unit = "rad/s" if DOFS[dof] else "m/s"
    sigma = None
    if slope < 0:
        grad = np.zeros(len(fit.names))
        for i, t in used:
            grad[i] = -way * float(t.phi(np.zeros(1), np.array([way * u]))[0]) / slope
        sigma = fit.combination_std(grad)
    name = f"terminal speed at {drive:.4g} {force_unit(dof)}"
    return Combination(way * u, sigma, unit, name=name)


def drag_at_speed(fit: FitStatistics, speed: float, dof: str) -> Combination | None:
    """D(u) = −Σ θ_j·φ_j(0, u) at the tested ``speed`` u (m/s or rad/s) over ``fit``'s kept
    force terms that depend on velocity alone, with σ_D² = gᵀ·C·g, g_j = −φ_j(0, u) (module
    doc); None at u = 0 or without such a term. N (a line) or N·m (a rotation)."""
    used = [
        (i, t)
        for i, n in enumerate(fit.names)
        if (t := LIBRARY.get(n)) is not None and t.role == "force" and t.v_power is not None
    ]
    if not used or not np.isfinite(speed) or speed == 0:
        return None
    grad = np.zeros(len(fit.names))
    for i, t in used:
        grad[i] = -float(t.phi(np.zeros(1), np.array([speed]))[0])
    drag = float(grad @ fit.values)
    sigma = fit.combination_std(grad)
    speed_unit = "rad/s" if DOFS[dof] else "m/s"
    return Combination(drag, sigma, force_unit(dof), name=f"drag at {speed:.4g} {speed_unit}")


def drags_at_speeds(
    fit: FitStatistics, speeds: Sequence[float], dof: str
) -> tuple[Combination, ...]:
    """``drag_at_speed`` at each distinct tested speed (the speed each run reached, m/s or
    rad/s), in order of size; speeds within 1 % of one already given are left out."""
    distinct: list[float] = []
    for u in sorted((float(u) for u in speeds if np.isfinite(u) and u != 0), key=abs):
        if not any(abs(u - w) <= 0.01 * abs(w) for w in distinct):
            distinct.append(u)
    found = (drag_at_speed(fit, u, dof) for u in distinct)
    return tuple(c for c in found if c is not None)


def natural_period(
    inertia: float,
    inertia_std: float | None,
    stiffness: float,
    stiffness_std: float | None,
    correlation: float = 0.0,
) -> Combination | None:
    """T₀ = 2π·√(M/k) [s] with σ: (σ_T/T)² = ¼·[(σ_M/M)² + (σ_k/k)² − 2ρ·(σ_M/M)(σ_k/k)]
    (a σ of 0 for a known value; None when either is not identified)."""
    if not (inertia > 0 and stiffness > 0):
        return None
    period = 2 * np.pi * np.sqrt(inertia / stiffness)
    sigma = None
    if inertia_std is not None and stiffness_std is not None:
        rm, rk = inertia_std / inertia, stiffness_std / stiffness
        rel2 = 0.25 * (rm**2 + rk**2 - 2 * correlation * rm * rk)
        sigma = float(period * np.sqrt(max(rel2, 0.0)))
    return Combination(float(period), sigma, "s", name="natural period T₀")


def natural_frequency(period: Combination) -> Combination:
    """ω₀ = 2π/T₀ [rad/s] with σ_ω = ω₀·σ_T/T₀ (first order in σ_T/T₀)."""
    omega = 2 * np.pi / period.value
    sigma = None if period.std is None else omega * period.std / period.value
    return Combination(float(omega), sigma, "rad/s", name="natural frequency ω₀")


def damping_ratio(
    equivalent: Coefficient, amplitude: float, inertia: float, omega: float, dof: str
) -> Combination | None:
    """ζ(a) = B_e(a)/(2·M·ω₀) at ``amplitude`` (m or rad) with σ from B_e's alone (the
    inertia's and ω₀'s relative σ are a fraction of it on a decay, ``motion.equivalent``)."""
    if not (inertia > 0 and omega > 0):
        return None
    scale = 1.0 / (2 * inertia * omega)
    unit = "rad" if DOFS[dof] else "m"
    shown = f"{np.rad2deg(amplitude):.3g}°" if DOFS[dof] else f"{amplitude:.3g} {unit}"
    return Combination(
        equivalent.value * scale,
        None if equivalent.std is None else equivalent.std * scale,
        "",
        name=f"damping ratio ζ at {shown}",
    )


def terminal_speeds(
    fit: FitStatistics, drives: Mapping[str, float], dof: str
) -> tuple[Combination, ...]:
    """``terminal_speed`` at each distinct constant drive of ``drives`` (per run, N or
    N·m), in order of size; drives without a steady speed are left out."""
    distinct: list[float] = []
    for d in sorted(drives.values(), key=abs):
        if np.isfinite(d) and d != 0 and not any(abs(d - e) <= 1e-9 * abs(e) for e in distinct):
            distinct.append(float(d))
    found = (terminal_speed(fit, d, dof) for d in distinct)
    return tuple(c for c in found if c is not None)


def inertia_and_stiffness(setup: Setup, record: Record, final: MotionFit) -> tuple[float, float]:
    """The whole inertia M (kg or kg·m²) and linear stiffness k (N/m or N·m/rad) on
    ``record``: known parts and identified ones with the record's weights (a pendulum's
    α·l²); the stiffness is the given or fitted spring, else gravity's moment per rad."""
    identified = final.value("inertia") if "inertia" in final.names else setup.inertia or 0.0
    total = known_inertia_of(record, setup) + record.weight("inertia") * float(identified)
    known = known_terms_of(record, setup)
    k = known.get("restoring_spring", known.get("sine_restoring"))
    if k is None:
        k = final.value("restoring_spring") * record.weight("restoring_spring")
    return float(total), float(k)


def decay_combinations(
    setup: Setup, record: Record, final: MotionFit, equivalent: Sequence[EquivalentDamping]
) -> tuple[Combination, ...]:
    """The natural period and frequency with their σ and the damping ratio at each swing
    amplitude of ``equivalent`` (``motion.well_determined``), on ``record`` (the first: its
    known parts and weights)."""

    def sigma(name: str) -> float | None:
        if name not in final.names:
            return 0.0  # known
        s = final.sigma(name) * record.weight(name)
        return float(s) if np.isfinite(s) else None

    total, k = inertia_and_stiffness(setup, record, final)
    rho = 0.0
    if "inertia" in final.names and "restoring_spring" in final.names:
        rho = float(
            final.correlation[final.names.index("inertia"), final.names.index("restoring_spring")]
        )
    out = [
        natural_period(
            total, sigma("inertia"), k, sigma("restoring_spring"), rho if np.isfinite(rho) else 0.0
        )
    ]
    period = out[0]
    if period is not None:
        out.append(natural_frequency(period))
        omega = 2 * np.pi / period.value
        out += [damping_ratio(e, e.amplitude, total, omega, setup.dof) for e in equivalent]
    return tuple(c for c in out if c is not None)
