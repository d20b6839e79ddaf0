"""Simulate the pendulum's nonlinear moment balance for many parameter sets at once.

    J·φ̈ = −k·sin φ − c·φ̇ − q·|φ̇|·φ̇ − τ_c·sgn φ̇,
    J = J_known + α·l²,  c = β·l² + b,  q = γ·l³

Fixed-step RK4 (vectorized over parameter sets, so a finite-difference Jacobian costs one
call) with exact handling of the dry friction: the friction torque is constant within a
step; a step in which the velocity reverses is split at the reversal, where the pendulum
sticks for good when |k·sin φ| ≤ τ_c (nothing else drives it). Grid values are mapped to
the sample times by cubic Hermite interpolation (φ and φ̇ are both known on the grid).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

STEPS_PER_PERIOD = 60  # RK4 at ω·h ≈ 0.1: relative error < 1e-6 per period
MAX_STEP_S = 0.1


@dataclass(frozen=True)
class Plant:
    """Known part of one run's pendulum: J_known (kg·m²), k (N·m/rad), b (N·m·s), l (m)."""

    known_inertia: float
    stiffness: float
    pivot_damping: float
    arm: float


def step_size(t: np.ndarray, plant: Plant, added_mass_guess: float = 0.0) -> float:
    """Integration step (s): ≤ period/60 and ≤ 0.1 s."""
    inertia = plant.known_inertia + max(added_mass_guess, 0.0) * plant.arm**2
    period = 2 * np.pi * np.sqrt(inertia / plant.stiffness)
    return float(min(MAX_STEP_S, period / STEPS_PER_PERIOD, max(t[-1] - t[0], 1e-3) / 10))


def _accel(phi, v, sign, k, inv_j, c, q, tau):
    return (-k * np.sin(phi) - c * v - q * np.abs(v) * v - tau * sign) * inv_j


def _rk4(phi, v, h, sign, k, inv_j, c, q, tau):
    a1 = _accel(phi, v, sign, k, inv_j, c, q, tau)
    p2, v2 = phi + 0.5 * h * v, v + 0.5 * h * a1
    a2 = _accel(p2, v2, sign, k, inv_j, c, q, tau)
    p3, v3 = phi + 0.5 * h * v2, v + 0.5 * h * a2
    a3 = _accel(p3, v3, sign, k, inv_j, c, q, tau)
    p4, v4 = phi + h * v3, v + h * a3
    a4 = _accel(p4, v4, sign, k, inv_j, c, q, tau)
    phi_new = phi + h / 6 * (v + 2 * v2 + 2 * v3 + v4)
    v_new = v + h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
    return phi_new, v_new


def simulate(
    plant: Plant,
    t: np.ndarray,
    added_mass: ArrayLike,
    linear_damping: ArrayLike,
    quadratic_damping: ArrayLike,
    dry_friction: ArrayLike,
    phi0: ArrayLike,
    rate0: ArrayLike,
    h: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Angle and rate (S, n) at sample times ``t`` (from t[0]) for S parameter sets.

    Coefficient arrays have shape (S,) (or are scalars): α (kg), β (N·s/m), γ (kg/m), τ_c (N·m), the
    state (φ, φ̇) at t[0] (rad, rad/s). Sets with J ≤ 0 come back as NaN.
    """
    given = (added_mass, linear_damping, quadratic_damping, dry_friction, phi0, rate0)
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(a, dtype=float)) for a in given))
    alpha, beta, gamma, tau, phi, v = (np.array(a, dtype=float) for a in arrays)
    arm = plant.arm
    inertia = plant.known_inertia + alpha * arm**2
    bad = ~(inertia > 0)
    inv_j = np.where(bad, 0.0, 1.0 / np.where(bad, 1.0, inertia))
    k, c, q = plant.stiffness, beta * arm**2 + plant.pivot_damping, gamma * arm**3
    tau = np.abs(tau)
    t = np.asarray(t, dtype=float)
    n_steps = max(int(np.ceil((t[-1] - t[0]) / h)), 1)
    h = (t[-1] - t[0]) / n_steps if t[-1] > t[0] else h
    phis = np.empty((n_steps + 1, phi.size))
    rates = np.empty_like(phis)
    stuck = (v == 0) & (k * np.abs(np.sin(phi)) <= tau)
    phis[0], rates[0] = phi, v
    for i in range(1, n_steps + 1):
        was_stuck = stuck
        sign = np.where(v != 0, np.sign(v), -np.sign(np.sin(phi)))
        p1, v1 = _rk4(phi, v, h, sign, k, inv_j, c, q, tau)
        reversed_ = (v1 * sign < 0) & ~was_stuck
        if np.any(reversed_ & (tau > 0)):
            # split the step at the reversal (velocity ≈ linear within the step)
            frac = np.clip(np.abs(v) / np.maximum(np.abs(v) + np.abs(v1), 1e-300), 0.0, 1.0)
            h1 = frac * h
            pa, va = _rk4(phi, v, h1, sign, k, inv_j, c, q, tau)
            # one Newton step on the reversal instant: φ̇(h1) = 0
            aa = _accel(pa, va, sign, k, inv_j, c, q, tau)
            h1 = np.clip(h1 - va / np.where(aa == 0, np.inf, aa), 0.0, h)
            pa, _ = _rk4(phi, v, h1, sign, k, inv_j, c, q, tau)
            sticks = reversed_ & (k * np.abs(np.sin(pa)) <= tau)
            new_sign = -np.sign(np.sin(pa))
            pb, vb = _rk4(pa, np.zeros_like(pa), h - h1, new_sign, k, inv_j, c, q, tau)
            split = reversed_ & (tau > 0)
            p1 = np.where(split, np.where(sticks, pa, pb), p1)
            v1 = np.where(split, np.where(sticks, 0.0, vb), v1)
            stuck = stuck | sticks
        phi = np.where(was_stuck, phi, p1)
        v = np.where(stuck, 0.0, v1)
        phis[i], rates[i] = phi, v
    grid = t[0] + h * np.arange(n_steps + 1)
    angle = _hermite(grid, phis, rates, t)
    rate = np.vstack([np.interp(t, grid, rates[:, j]) for j in range(phis.shape[1])])
    angle[bad] = np.nan
    rate[bad] = np.nan
    return angle, rate


def _hermite(grid: np.ndarray, y: np.ndarray, dy: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Cubic Hermite interpolation of (N, S) grid values to (S, n) at times t."""
    h = grid[1] - grid[0]
    idx = np.clip(((t - grid[0]) / h).astype(int), 0, grid.size - 2)
    s = ((t - grid[idx]) / h)[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    out = h00 * y[idx] + h10 * h * dy[idx] + h01 * y[idx + 1] + h11 * h * dy[idx + 1]
    return out.T.copy()
