"""What a test would teach: predicted record, duration and Fisher information of one run.

Model of one axis, from rest, constant signed load τ, direction s = sign(τ)::

    (M + m_w)·v̇ = τ − K_L·v − K_Q·|v|·v − F_c·s + b

θ = (M, K_L, K_Q, F_c, b); ``m_w`` the hung weight's inertia (|τ|/g for a tow, |τ|·r/g for
a spin on a drum of radius r). The run ends at the travel limit or after ``max_time_s``.
The position x(t) is sampled at ``rate_hz``; with white position noise of σ_x the run's
information on θ is  I = Jᵀ·J / σ_x²,  J = ∂x(t_k)/∂θ by central differences, with its
mean over the run removed (the fit's per-run position offset). The planner
adds it to the information of the runs already recorded to predict the covariance after
the run (``estimation.design.planner``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.design.planning_envelope import AxisEnvelope, Candidate
from estimation.loop_choice import LoopChoice

PARAMETERS = ("inertia", "linear_damping", "quadratic_damping", "coulomb_friction", "constant_bias")
#: Integration step, s (semi-implicit Euler; BENBAM's time constants are ≥ 1 s).
STEP_S = 0.01
#: Relative step of the central differences.
DIFF_STEP = 1e-4
#: Samples before the release and after the brake, s (the procedures' defaults).
BASELINE_S = 1.0
TAIL_S = 0.3


@dataclass(frozen=True)
class Prediction:
    """A run's predicted duration (s, baseline and tail included), peak rate and information
    (5×5 over ``PARAMETERS``, for unit position noise: divide by σ_x²)."""

    duration_s: float
    peak_rate: float
    information: np.ndarray
    moves: bool


def hung_inertia(env: AxisEnvelope, test: Candidate, g: float) -> float:
    """The inertia the drive adds: the hung weight (kg for a tow, kg·m² on a spin drum)."""
    if test.drive != "weight":
        return 0.0
    if env.axis == "surge":
        return abs(test.load) / g  # kg
    radius = env.drum_radius_m or 0.0
    return abs(test.load) * radius / g  # (|τ|/(g·r))·r², kg·m²


#: Steps a process takes in the NumPy loop, in all, before it loads the compiled one (numba:
#: ~0.6 s of CPU and ~110 MB resident, docs/api.md): ~25 µs a step, so at most ~0.5 s spent
#: before a load that turns out to be needed after all; a process that has loaded numba
#: already (an estimate that integrated) steps compiled from the first.
NUMPY_STEPS = 20_000


#: The process's choice (``_simulate`` asks it before each prediction): compiled
#: (``compiled_prediction``, the same bits) once numba is loaded, by an estimate or by this.
LOOP = LoopChoice("numba", NUMPY_STEPS)


def _simulate(
    theta: np.ndarray, load: float, extra: float, travel: float, t_end: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Positions (rows: parameter sets) every ``STEP_S`` until ``t_end`` or the nominal set
    (row 0) reaches ``travel``; returns (x, t, peak rate of row 0). Semi-implicit Euler, in
    the loop ``LOOP`` chooses."""
    n = int(t_end / STEP_S)
    if LOOP.compiled():
        xs = compiled_run(theta, load, extra, travel, n)
    else:
        xs = numpy_run(theta, load, extra, travel, n)
        LOOP.stepped_in_numpy(len(xs))
    t = STEP_S * np.arange(1, len(xs) + 1)
    return xs, t, float(np.max(np.abs(np.diff(xs[:, 0])) / STEP_S, initial=0.0))


def numpy_run(theta: np.ndarray, load: float, extra: float, travel: float, n: int) -> np.ndarray:
    """``n`` steps (fewer when set 0 reaches ``travel``) of every set at once, in NumPy:
    ~15 array operations a step on arrays of one number per set."""
    s = np.sign(load)
    m, kl, kq, fc, b = (theta[:, i] for i in range(5))
    net_static = abs(load) - np.maximum(fc, 0.0)
    x = np.zeros(len(theta))
    v = np.zeros(len(theta))
    xs = np.empty((n, len(theta)))
    for k in range(n):
        a = (load - kl * v - kq * np.abs(v) * v - fc * s + b) / (m + extra)
        a = np.where((v == 0) & (net_static <= 0), 0.0, a)
        v = v + a * STEP_S
        v = np.where(v * s < 0, 0.0, v)  # friction never drives the body backwards
        x = x + v * STEP_S
        xs[k] = x
        if abs(x[0]) >= travel:
            return xs[: k + 1]
    return xs


def compiled_run(theta: np.ndarray, load: float, extra: float, travel: float, n: int) -> np.ndarray:
    """``numpy_run`` stepped by the compiled loop (``compiled_prediction``: numba, loaded
    here), one set after another: the same bits."""
    from estimation.design.compiled_prediction import run_from_rest

    m, kl, kq, fc, b = np.ascontiguousarray(np.asarray(theta, dtype=float).T)
    stuck = abs(load) - np.maximum(fc, 0.0) <= 0
    direction = float(np.sign(load))
    return run_from_rest(
        m, kl, kq, fc, b, stuck, float(load), direction, float(extra), STEP_S, float(travel), n
    )


def predict(
    theta: np.ndarray,
    env: AxisEnvelope,
    test: Candidate,
    g: float,
    rate_hz: float = 10.0,
    max_time_s: float = 120.0,
) -> Prediction:
    """Duration, peak rate and information of ``test`` under the model ``theta``."""
    return predict_lengths(theta, env, [test], g, rate_hz, max_time_s)[0]


def predict_lengths(
    theta: np.ndarray,
    env: AxisEnvelope,
    tests: Sequence[Candidate],
    g: float,
    rate_hz: float = 10.0,
    max_time_s: float = 120.0,
) -> list[Prediction]:
    """``predict`` of each of ``tests`` — one load and drive, stopped at different travels
    (``Candidate.travel``) — from one integration: a run stopped short is the beginning of
    the longest, cut where the body first reaches its travel."""
    (load,) = {t.load for t in tests}
    room = env.room(load)
    travels = [room if t.travel is None else min(t.travel, room) for t in tests]
    extra = hung_inertia(env, tests[0], g)
    scale = np.maximum(np.abs(theta), 1e-3 * np.maximum(np.abs(theta[:3]).max(), 1.0))
    sets = [theta]
    for i in range(len(theta)):
        for sign in (1.0, -1.0):
            d = np.array(theta, dtype=float)
            d[i] += sign * DIFF_STEP * scale[i]
            sets.append(d)
    xs_all, t_all, _ = _simulate(np.array(sets), load, extra, max(travels), max_time_s)
    every = max(1, round(1.0 / rate_hz / STEP_S))
    out = []
    for travel in travels:
        reached = np.flatnonzero(np.abs(xs_all[:, 0]) >= travel)
        end = int(reached[0]) + 1 if len(reached) else len(xs_all)
        x_run, t = xs_all[:end], t_all[:end]
        peak = float(np.max(np.abs(np.diff(x_run[:, 0])) / STEP_S, initial=0.0))
        xs = x_run[every - 1 :: every]
        jac = np.column_stack(
            [
                (xs[:, 1 + 2 * i] - xs[:, 2 + 2 * i]) / (2 * DIFF_STEP * scale[i])
                for i in range(len(theta))
            ]
        )
        # the fit takes one position offset per run (a nuisance): only J's part orthogonal
        # to a constant carries information on θ
        jac = jac - jac.mean(axis=0)
        moving = bool(abs(xs[-1, 0]) > 1e-3) if len(xs) else False
        duration = BASELINE_S + float(t[-1] if len(t) else max_time_s) + TAIL_S
        out.append(Prediction(duration, peak, jac.T @ jac, moving))
    return out
