"""Axis model simulation: closed form for constant drive, RK4 otherwise.

Model (per axis, SI):  (M + M_drive + k·|τ|/g)·v̇ = τ + b − F_c·sign(v) − K_L·v − K_Q·|v|·v
                        − K_C·v³ − k_s·(x − x_release),  motion starting at t_release + δ.
Parameters are evaluated for S parameter sets at once (rows of ``theta``) so Jacobians by
finite differences cost one vectorized call.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.axis.effects import STANDARD_GRAVITY
from estimation.data.runs import RunData

BASE_NAMES: tuple[str, ...] = ("inertia", "linear_damping", "quadratic_damping")
RK4_MAX_STEP_S = 0.1  # RK4 error < 1e-6 m on BENBAM-like dynamics (τ ≥ 0.5 s)
BASELINE_KEPT_S = 0.0  # at-rest samples carry a fixed quantization error: not fitted


@dataclass(frozen=True)
class PreparedRun:
    """The usable part of a run, in arrays the simulators read."""

    run_id: str
    t: np.ndarray
    x: np.ndarray
    drive: np.ndarray  # per sample
    constant_drive: float | None
    t_release: float
    extra_inertia: float
    mean_abs_drive: float
    weight_equivalent: float  # |τ|/g when the hung weight is undeclared, else 0 (drive_inertia)
    t_release_std: float = 0.0  # 1σ uncertainty of the release instant, s
    #: The drive held from the last sample at or before the release until the first kept
    #: sample (per-sample drives; None: ``drive[0]``).
    drive_at_release: float | None = None


def prepare(run: RunData) -> PreparedRun:
    """Cut a run to its usable window and precompute what the simulators need."""
    keep = run.window() & (np.asarray(run.t) > run.t_release - BASELINE_KEPT_S)
    t = np.asarray(run.t, dtype=float)[keep]
    drive = run.drive_at_samples()[keep]
    moving = t > run.t_release
    const = float(np.asarray(run.drive)) if run.is_constant_drive() else None
    mean_abs = float(np.mean(np.abs(drive[moving]))) if moving.any() else 0.0
    return PreparedRun(
        run_id=run.run_id,
        t=t,
        x=np.asarray(run.position, dtype=float)[keep],
        drive=drive,
        constant_drive=const,
        t_release=float(run.t_release),
        extra_inertia=run.declared_extra_inertia(),
        mean_abs_drive=mean_abs,
        weight_equivalent=(
            mean_abs / STANDARD_GRAVITY
            if const is not None and not run.hung_mass_declared()
            else 0.0
        ),
        t_release_std=float(run.t_release_std),
        drive_at_release=_held_at(run, run.t_release),
    )


def _held_at(run: RunData, instant: float) -> float | None:
    """The per-sample drive held at ``instant`` (the last sample at or before it)."""
    if run.is_constant_drive():
        return None
    before = np.nonzero(np.asarray(run.t) <= instant)[0]
    return float(run.drive_at_samples()[before[-1]]) if before.size else None


class ParamView:
    """Named columns of a (S, G) parameter matrix; absent effects read as zero."""

    def __init__(self, theta: np.ndarray, effects: Sequence[str]) -> None:
        self.theta = theta
        self.index = {name: i for i, name in enumerate((*BASE_NAMES, *effects))}

    def __getitem__(self, name: str) -> np.ndarray:
        i = self.index.get(name)
        if i is None:
            return np.zeros(self.theta.shape[0])
        return self.theta[:, i]


def closed_form_applies(effects: Sequence[str], runs: Sequence[PreparedRun]) -> bool:
    """True when every run has constant drive and no state-dependent effect is active."""
    if "restoring_spring" in effects or "cubic_drag" in effects:
        return False
    return all(r.constant_drive is not None for r in runs)


def constant_force_response(
    tau: np.ndarray, inertia: np.ndarray, k_l: np.ndarray, k_q: np.ndarray, force: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and velocity from rest under a constant force ≥ 0 (closed form).

    Solves M v̇ = F − K_L v − K_Q v², v(0) = 0:  v = v∞(1 − E)/(1 + aE), E = e^{−λt},
    λ = √(K_L² + 4K_Q F)/M, v∞ = 2F/(K_L + √·), a = 4K_Q F/(K_L + √·)²;
    x = v∞[t + (1 + a)/λ · (ln(1 + aE) − ln(1 + a))/a]. Parameter arrays broadcast as (S, 1).
    """
    disc = np.sqrt(k_l**2 + 4.0 * k_q * force)
    denom = np.maximum(k_l + disc, 1e-300)
    v_inf = 2.0 * force / denom
    a = 4.0 * k_q * force / denom**2
    lam = np.maximum(disc, 1e-300) / inertia
    e = np.exp(-lam * tau)
    small = a < 1e-7
    a_safe = np.where(small, 1.0, a)
    ratio = np.where(
        small,
        (e - 1.0) - a * (e * e - 1.0) / 2.0,
        (np.log1p(a_safe * e) - np.log1p(a_safe)) / a_safe,
    )
    x = v_inf * (tau + (1.0 + a) / lam * ratio)
    v = v_inf * (1.0 - e) / (1.0 + a * e)
    return x, v


def _simulate_closed(
    p: ParamView, runs: Sequence[PreparedRun]
) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    col = lambda name: p[name][:, None]  # noqa: E731
    for r in runs:
        force = r.constant_drive
        assert force is not None
        inertia = col("inertia") + r.extra_inertia + col("drive_inertia") * r.weight_equivalent
        net = force + col("constant_bias")
        f_eff = np.maximum(np.abs(net) - col("coulomb_friction"), 0.0)
        tau = np.maximum(r.t[None, :] - r.t_release - col("release_delay"), 0.0)
        x, v = constant_force_response(
            tau, inertia, col("linear_damping"), col("quadratic_damping"), f_eff
        )
        s = np.sign(net)
        out.append((s * x, s * v))
    return out


def _hermite(grid_x, grid_v, h, tau):
    """Cubic Hermite interpolation on a uniform grid; grid arrays (K, S), tau (S, n)."""
    k_max = grid_x.shape[0] - 2
    k = np.clip(np.floor(tau / h).astype(int), 0, k_max)
    s = np.clip(tau / h - k, 0.0, 1.0)
    cols = np.arange(grid_x.shape[1])[:, None]
    x0, x1 = grid_x[k, cols], grid_x[k + 1, cols]
    v0, v1 = grid_v[k, cols] * h, grid_v[k + 1, cols] * h
    s2, s3 = s * s, s * s * s
    x = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * x1
    x = x + (s3 - s2) * v1
    v = ((6 * s2 - 6 * s) * x0 + (3 * s2 - 4 * s + 1) * v0 + (6 * s - 6 * s2) * x1) / h
    v = v + (3 * s2 - 2 * s) * v1 / h
    return x, v


def _zoh_integral_at_samples(r: PreparedRun) -> np.ndarray:
    """∫ drive dt from the first sample to each sample (drive held until the next one)."""
    return np.concatenate([[0.0], np.cumsum(r.drive[:-1] * np.diff(r.t))])


def _zoh_integral(r: PreparedRun, cumulative: np.ndarray, t: np.ndarray) -> np.ndarray:
    """∫ drive dt from the first kept sample to ``t`` (held drive; before the first kept
    sample the drive held at the release, after the last one the last value)."""
    j = np.clip(np.searchsorted(r.t, t, side="right") - 1, 0, r.t.size - 1)
    inside = cumulative[j] + r.drive[j] * (t - r.t[j])
    early = r.drive[0] if r.drive_at_release is None else r.drive_at_release
    return np.where(t < r.t[0], early * (t - r.t[0]), inside)


def _simulate_ode(p: ParamView, runs: Sequence[PreparedRun]) -> list[tuple[np.ndarray, np.ndarray]]:
    h = RK4_MAX_STEP_S
    if any(r.constant_drive is None for r in runs):  # one step per held thrust sample
        h = min(h, min(float(np.median(np.diff(r.t))) for r in runs if r.t.size > 1))
    delay = p["release_delay"]
    span = max(float(r.t[-1] - r.t_release) for r in runs) - min(0.0, float(delay.min()))
    n_steps = max(int(np.ceil(span / h)) + 2, 3)
    n_sets, n_runs = p.theta.shape[0], len(runs)
    inertia = np.empty((n_sets, n_runs))
    const_force = np.zeros((n_sets, n_runs))
    varying = [i for i, r in enumerate(runs) if r.constant_drive is None]
    for i, r in enumerate(runs):
        inertia[:, i] = p["inertia"] + r.extra_inertia + p["drive_inertia"] * r.weight_equivalent
        const_force[:, i] = (r.constant_drive or 0.0) + p["constant_bias"]
    k_l, k_q = p["linear_damping"][:, None], p["quadratic_damping"][:, None]
    k_c, k_s = p["cubic_drag"][:, None], p["restoring_spring"][:, None]
    f_c = p["coulomb_friction"][:, None]

    # The recorded drive is a zero-order hold (each value until the next sample): its running
    # integral at the sample instants, so a step takes the drive's exact mean over its span
    # even when the steps do not line up with the samples (release between two samples).
    held = {i: _zoh_integral_at_samples(runs[i]) for i in varying}

    def mean_force(step_start: float) -> np.ndarray:
        f = const_force.copy()
        for i in varying:
            r = runs[i]
            a = step_start + r.t_release + delay
            f[:, i] += (_zoh_integral(r, held[i], a + h) - _zoh_integral(r, held[i], a)) / h
        return f

    has_cubic, has_spring = bool(np.any(k_c)), bool(np.any(k_s))
    has_coulomb = bool(np.any(f_c))
    inv_inertia = 1.0 / inertia

    def accel(x, v, force):
        net = force - (k_l + k_q * np.abs(v)) * v
        if has_cubic:
            net = net - k_c * v**3
        if has_spring:
            net = net - k_s * x
        if not has_coulomb:
            return net * inv_inertia
        direction = np.where(v != 0.0, np.sign(v), np.sign(net))
        stuck = (v == 0.0) & (np.abs(net) <= f_c)
        return np.where(stuck, 0.0, (net - f_c * direction) * inv_inertia)

    xs = np.zeros((n_steps, n_sets, n_runs))
    vs = np.zeros((n_steps, n_sets, n_runs))
    x = np.zeros((n_sets, n_runs))
    v = np.zeros((n_sets, n_runs))
    for k in range(1, n_steps):
        t0 = (k - 1) * h
        if varying:
            # the recorded drive is a zero-order hold between samples: its mean over the step
            f0 = fh = f1 = mean_force(t0)
        else:
            f0 = fh = f1 = const_force
        a1 = accel(x, v, f0)
        a2 = accel(x + 0.5 * h * v, v + 0.5 * h * a1, fh)
        a3 = accel(x + 0.5 * h * (v + 0.5 * h * a1), v + 0.5 * h * a2, fh)
        a4 = accel(x + h * (v + 0.5 * h * a2), v + h * a3, f1)
        x = x + h * v + h * h / 6.0 * (a1 + a2 + a3)
        v = v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
        xs[k], vs[k] = x, v
    out = []
    for i, r in enumerate(runs):
        tau = np.maximum(r.t[None, :] - r.t_release - delay[:, None], 0.0)
        out.append(_hermite(xs[:, :, i], vs[:, :, i], h, tau))
    return out


def simulate(
    theta: np.ndarray, effects: Sequence[str], runs: Sequence[PreparedRun]
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Displacement from the release position and velocity, per run, shape (S, n_samples).

    ``theta`` has one row per parameter set: inertia, K_L, K_Q, then one column per effect.
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    p = ParamView(theta, effects)
    if closed_form_applies(effects, runs):
        return _simulate_closed(p, runs)
    # A trial parameter set far from the data (e.g. an effect search's first step on a
    # short run) can diverge; its non-finite residual rejects it, so no warning is needed.
    with np.errstate(over="ignore", invalid="ignore"):
        return _simulate_ode(p, runs)
