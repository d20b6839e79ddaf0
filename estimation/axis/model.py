"""Axis model simulation: the one equation (``estimation.motion.equation``) from rest at
the release, in closed form for a constant drive when every term allows it, else by RK4.

Model (per axis, SI):  (M + M_drive + Σ θ_i·w_i)·v̇ = τ + Σ_j θ_j·φ_j(x − x_release, v),
motion starting at t_release + Σ δ (timing terms). The base is inertia M and the library
entries ``linear_damping`` (K_L) and ``quadratic_damping`` (K_Q); each effect is one more
entry (``estimation.motion.terms``) that carries its own regressor, so nothing here names
one. Parameters are evaluated for S parameter sets at once (rows of ``theta``) so Jacobians
by finite differences cost one vectorized call.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.prepared_run import PreparedRun
from estimation.motion import equation
from estimation.motion.equation import Track, integrate, integration_step
from estimation.motion.terms import LIBRARY, Term, TermValues

BASE_NAMES: tuple[str, ...] = ("inertia", "linear_damping", "quadratic_damping")


class ParamView:
    """A (S, G) parameter matrix read as the equation's parts: the inertia column and one
    ``TermValues`` per library entry (base damping, then effects), grouped by role."""

    def __init__(self, theta: np.ndarray, effects: Sequence[str]) -> None:
        self.theta, self.effects = theta, tuple(effects)
        self.inertia = theta[:, 0]
        entries = [LIBRARY[name] for name in (*BASE_NAMES[1:], *effects)]
        self.terms = [TermValues(t, theta[:, [i + 1]]) for i, t in enumerate(entries)]
        self.forces = [c for c in self.terms if c.term.role == "force"]
        self.inertias = [c for c in self.terms if c.term.role == "inertia"]
        self.timings = [c for c in self.terms if c.term.role == "timing"]

    def total_inertia(self, run: PreparedRun) -> np.ndarray:
        """M + M_drive + Σ θ_i·w_i per parameter set (kg or kg·m²), shape (S,)."""
        total = self.inertia + run.extra_inertia
        for c in self.inertias:
            total = total + c.value[:, 0] * run.weight_equivalent
        return total

    def rows(self, rows: slice) -> ParamView:
        """The view of the parameter sets ``theta[rows]``."""
        return ParamView(self.theta[rows], self.effects)

    def delay(self) -> np.ndarray:
        """Σ of the timing terms (s), shape (S,)."""
        out = np.zeros(self.theta.shape[0])
        for c in self.timings:
            out = out + c.value[:, 0]
        return out


def _closed_form_term(term: Term) -> bool:
    """A force term a constant-force tow from rest can carry in closed form: independent of
    x, and of v only as v (K_L), |v|·v (K_Q) or sign(v)/a constant."""
    return term.role != "force" or (term.x_power is None and term.v_power in (0, 1, 2))


def closed_form_applies(effects: Sequence[str], runs: Sequence[PreparedRun]) -> bool:
    """True when every run has constant drive and every active term allows the closed form."""
    terms = [LIBRARY[name] for name in (*BASE_NAMES[1:], *effects)]
    return all(map(_closed_form_term, terms)) and all(r.constant_drive is not None for r in runs)


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


def _closed_form_parts(p: ParamView) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """K_L, K_Q, and the constant forces when moving forward and backward, each (S, 1):
    Σ θ·(−φ(0, 1)) over the v and |v|·v terms, Σ θ·φ(0, ±1) over the constant ones."""
    n = p.theta.shape[0]
    k_l, k_q = np.zeros((n, 1)), np.zeros((n, 1))
    forward, backward = np.zeros((n, 1)), np.zeros((n, 1))
    zero, one = np.zeros(1), np.ones(1)
    for c in p.forces:
        if c.term.v_power == 1:
            k_l = k_l - c.value * c.term.phi(zero, one)
        elif c.term.v_power == 2:
            k_q = k_q - c.value * c.term.phi(zero, one)
        else:
            forward = forward + c.value * c.term.phi(zero, one)
            backward = backward + c.value * c.term.phi(zero, -one)
    return k_l, k_q, forward, backward


def _simulate_closed(
    p: ParamView, runs: Sequence[PreparedRun]
) -> list[tuple[np.ndarray, np.ndarray]]:
    """From rest at the release under F: moves forward when F + Σ θ·φ(0, +1) > 0, backward
    when F + Σ θ·φ(0, −1) < 0 (dry friction holds it otherwise), with that net force."""
    out = []
    k_l, k_q, forward, backward = _closed_form_parts(p)
    delay = p.delay()[:, None]
    for r in runs:
        force = r.constant_drive
        assert force is not None
        inertia = p.total_inertia(r)[:, None]
        ahead, behind = force + forward, force + backward
        s = np.where(ahead > 0, 1.0, np.where(behind < 0, -1.0, 0.0))
        f_eff = np.where(ahead > 0, ahead, np.where(behind < 0, -behind, 0.0))
        tau = np.maximum(r.t[None, :] - r.t_release - delay, 0.0)
        x, v = constant_force_response(tau, inertia, k_l, k_q, f_eff)
        out.append((s * x, s * v))
    return out


def at_step_limit(values: np.ndarray, effects: Sequence[str], runs: Sequence[PreparedRun]) -> bool:
    """Whether ``values`` need the one integrator's finest step or nearly
    (``motion.equation.at_step_limit``): a fit there may rest on it, not on the data."""
    if closed_form_applies(effects, runs):
        return False
    p = ParamView(np.atleast_2d(values), effects)
    return equation.at_step_limit(_tracks(runs), _inertia(p, runs), p.forces)


def step_of(
    theta: np.ndarray, effects: Sequence[str], runs: Sequence[PreparedRun]
) -> tuple[float, np.ndarray]:
    """The one integrator's RK4 step (s) for the parameter sets ``theta`` (S, G) on ``runs``,
    and which sets it cannot resolve (``motion.equation.integration_step``)."""
    p = ParamView(np.atleast_2d(theta), effects)
    return integration_step(_tracks(runs), _inertia(p, runs), p.forces)


def _inertia(p: ParamView, runs: Sequence[PreparedRun]) -> np.ndarray:
    """Each set's total inertia on each run (kg or kg·m²), shape (S, R)."""
    return np.column_stack([p.total_inertia(r) for r in runs])


def _tracks(runs: Sequence[PreparedRun]) -> list[Track]:
    """Each run as the one integrator reads it: τ from its release (held at rest before
    it), its drive per sample and the drive held at the release, its travel as the scale
    of the divergence guard. M_drive and the hung weight's inertia are in the total inertia
    ``ParamView.total_inertia`` passes, not here."""
    return [
        Track(
            r.t - r.t_release,
            r.drive,
            scale=float(np.ptp(r.x)) or 1.0,
            drive_before=r.drive_at_release,
            reach=r.peak_excursion,
            speed=r.peak_speed,
        )
        for r in runs
    ]


def _simulate_ode(
    every: ParamView, runs: Sequence[PreparedRun], rows: slice
) -> list[tuple[np.ndarray, np.ndarray]]:
    """From rest at each set's release (the run's, later by the timing terms) by the one
    integrator (``motion.equation.integrate``), on the step it chooses for every set of
    ``every``: the sets of ``rows`` only, so each set's path is the same whichever sets run
    beside it."""
    tracks = _tracks(runs)
    h, unresolved = integration_step(tracks, _inertia(every, runs), every.forces)
    p = every.rows(rows)
    n_sets = p.theta.shape[0]
    inertia = _inertia(p, runs)
    # terms that are zero in every set exert nothing: skipped (dry friction's set-valued
    # branch costs most)
    forces = [c for c, e in zip(p.forces, every.forces, strict=True) if np.any(e.value)]
    rest = np.zeros((n_sets, len(runs)))
    return integrate(
        tracks, inertia, forces, rest, rest, h, shift=p.delay(), unresolved=unresolved[rows]
    )


#: A simulated position beyond this multiple of the measured travel is a diverged trial.
DIVERGED_TRAVELS = 1e3


def bounded(x: np.ndarray, runs: Sequence[PreparedRun]) -> np.ndarray:
    """Simulated positions held within ±DIVERGED_TRAVELS × (the runs' travel + 1) (m or rad),
    NaN at the bound: a diverged trial becomes a large, finite misfit where it starts, so
    no overflow reaches a fit, a sensitivity or a norm."""
    big = DIVERGED_TRAVELS * (max((float(np.ptp(r.x)) for r in runs), default=0.0) + 1.0)
    return np.clip(np.nan_to_num(x, nan=big, posinf=big, neginf=-big), -big, big)


def simulate(
    theta: np.ndarray,
    effects: Sequence[str],
    runs: Sequence[PreparedRun],
    rows: slice = slice(None),
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Displacement from the release position and velocity, per run, shape (S, n_samples).

    ``theta`` has one row per parameter set: inertia, K_L, K_Q, then one column per effect.
    ``rows``: simulate only the sets ``theta[rows]``, on the RK4 step and grid all the
    sets of ``theta`` would share (a finite-difference Jacobian's perturbed sets after its
    centre's residual: the same numbers as simulating them all at once).
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    p = ParamView(theta, effects)
    if closed_form_applies(effects, runs):
        return _simulate_closed(p.rows(rows), runs)
    # A trial parameter set far from the data (e.g. an effect search's first step on a
    # short run) can diverge; its non-finite residual rejects it, so no warning is needed.
    with np.errstate(over="ignore", invalid="ignore"):
        return _simulate_ode(p, runs, rows)
