"""The thrust's response time, measured from a calibration's step responses.

Every calibration step is a step response: the controller confirms a new output u(t) (held
until the next; ramps are a run of small steps), the thrust follows it with a first-order
lag, and the load cell reads it. With the calibration's own curve F(u) and n thrusters on
the load cell, the reading at a sample time t_k is

    y(t_k) = n · (F ∘ u) filtered by  τ·dF̃/dt + F̃ = F(u(t)),   sampled at t_k,

and τ is the one unknown: it is found by least squares over the samples within
``WINDOW_S`` after each change of output (the plateaus carry no information on τ, only the
curve's lack of fit). σ_τ = √(s² / J'J)·√(N / K), with J = ∂y/∂τ at the samples, s² the
residual variance over the N samples and K the transients: the samples of one transient
share that step's curve error, so K, not N, counts the independent pieces of evidence.
The 90 % settling time of a first-order lag is τ·ln 10.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.signal import lfilter

from estimation.thrust.curve import CalibratedThrust, ThrustCurve

#: Samples this long after an output change are fitted (s): about 5 τ of a fast thruster.
WINDOW_S = 1.0
#: Grid of the lag filter (s).
GRID_S = 0.001
#: Bounds of the search (s): faster than the grid is not measurable, slower than this is
#: not a thruster's response but a fault.
TAU_BOUNDS_S = (0.002, 3.0)
#: Fewest output changes with samples in their window for a measurement.
MIN_TRANSIENTS = 4


@dataclass(frozen=True)
class ResponseTime:
    """The measured thrust time constant τ ± σ (s), its 90 % settling time (s), and what
    it rests on."""

    time_constant_s: float
    std_s: float
    settle_90_s: float
    transients: int
    samples: int
    rmse_n: float

    def to_json(self) -> dict:
        return {
            "time_constant_s": self.time_constant_s,
            "std_s": self.std_s,
            "settle_90_s": self.settle_90_s,
            "transients": self.transients,
            "samples": self.samples,
            "rmse_n": self.rmse_n,
        }


def lagged_thrust(
    curve: ThrustCurve | CalibratedThrust,
    steps: Sequence[tuple[float, Sequence[float]]],
    t: np.ndarray,
    tau: float,
) -> np.ndarray:
    """Σ over thrusters of F(u_i) through a first-order lag τ, at the instants ``t`` (s,
    on the steps' clock); outputs are zero before the first step."""
    grid = np.arange(float(t[0]) - WINDOW_S, float(t[-1]) + GRID_S, GRID_S)
    times = np.array([s for s, _ in steps], dtype=float)
    values = np.array([list(f) for _, f in steps], dtype=float)
    index = np.searchsorted(times, grid, side="right") - 1
    outputs = np.where(index[:, None] >= 0, values[np.clip(index, 0, None)], 0.0)
    force = np.sum([curve.force(outputs[:, i]) for i in range(values.shape[1])], axis=0)
    alpha = 1.0 - math.exp(-GRID_S / tau)
    lagged = lfilter([alpha], [1.0, alpha - 1.0], force, zi=[(1.0 - alpha) * force[0]])[0]
    return np.interp(t, grid, lagged)


def measure_response_time(
    curve: ThrustCurve | CalibratedThrust,
    steps: Sequence[tuple[float, Sequence[float]]],
    t: np.ndarray,
    load_n: np.ndarray,
) -> ResponseTime | None:
    """τ from the load cell ``load_n`` (tared, N, all thrusters) at times ``t`` (s) and the
    confirmed output ``steps`` (instant s, fraction per thruster); None with fewer than
    ``MIN_TRANSIENTS`` output changes followed by samples."""
    t, load = np.asarray(t, dtype=float), np.asarray(load_n, dtype=float)
    good = np.isfinite(t) & np.isfinite(load)
    t, load = t[good], load[good]
    times = np.array([s for s, _ in steps], dtype=float)
    if t.size < 3 or times.size == 0:
        return None
    since = t[:, None] - times[None, :]
    near = np.any((since > 0) & (since <= WINDOW_S), axis=1)
    transients = int(np.sum([np.any((t > s) & (t <= s + WINDOW_S)) for s in times]))
    if transients < MIN_TRANSIENTS:
        return None

    def model(tau: float) -> np.ndarray:
        return lagged_thrust(curve, steps, t, tau)[near]

    lo, hi = (math.log(b) for b in TAU_BOUNDS_S)
    best = minimize_scalar(
        lambda log_tau: float(np.sum((load[near] - model(math.exp(log_tau))) ** 2)),
        bounds=(lo, hi),
        method="bounded",
    )
    tau = math.exp(best.x)
    residual = load[near] - model(tau)
    h = 0.01 * tau
    jac = (model(tau + h) - model(tau - h)) / (2 * h)
    n = residual.size
    s2 = float(residual @ residual) / max(n - 1, 1)
    jtj = float(jac @ jac)
    std = math.sqrt(s2 / jtj * n / transients) if jtj > 0 else math.inf
    return ResponseTime(
        time_constant_s=tau,
        std_s=std,
        settle_90_s=tau * math.log(10.0),
        transients=transients,
        samples=int(n),
        rmse_n=float(np.sqrt(np.mean(residual**2))),
    )


def largest_transient(
    curve: ThrustCurve | CalibratedThrust,
    steps: Sequence[tuple[float, Sequence[float]]],
    t: np.ndarray,
    load_n: np.ndarray,
    tau: float,
) -> dict[str, list[float]]:
    """The samples from 0.3 s before to ``WINDOW_S`` after the output change with the
    largest jump in modelled thrust, measured and modelled (for the report's figure):
    ``{t_s, measured_n}`` at the samples and ``{model_t_s, model_n}`` on a 10 ms grid
    (times from the change, s)."""
    t, load = np.asarray(t, dtype=float), np.asarray(load_n, dtype=float)
    times = np.array([s for s, _ in steps], dtype=float)
    level = np.array([float(np.sum(curve.force(np.asarray(f, dtype=float)))) for _, f in steps])
    jumps = np.abs(np.diff(np.concatenate([[0.0], level])))
    start = float(times[int(np.argmax(jumps))])
    near = (t >= start - 0.3) & (t <= start + WINDOW_S) & np.isfinite(load)
    fine = np.arange(start - 0.3, start + WINDOW_S, 0.01)
    return {
        "t_s": (t[near] - start).tolist(),
        "measured_n": load[near].tolist(),
        "model_t_s": (fine - start).tolist(),
        "model_n": lagged_thrust(curve, steps, fine, tau).tolist(),
    }
