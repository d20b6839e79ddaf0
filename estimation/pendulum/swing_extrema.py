"""A free decay cut from its run, its noise level, and its extrema (both signs) with the
exponential (viscous) and linear (dry-friction) envelopes of their magnitudes."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.optimize import minimize_scalar

from estimation.motion.records import Record
from estimation.pendulum.configuration import record_of
from estimation.pendulum.data import PendulumGeometry, PendulumRun

MIN_EXTREMA = 3


@dataclass(frozen=True)
class Decay:
    """One run cut to its free decay: t (s, absolute), φ (rad), the known geometry, noise."""

    run_id: str
    t: np.ndarray
    phi: np.ndarray
    geometry: PendulumGeometry
    noise: float  # rad, 1σ of the sample-to-sample noise (incl. quantization)
    t_release_std: float = 0.0

    def record(self) -> Record:
        """The decay as a record of the one equation, its geometry as known terms: the same
        object every time (the fit's tracks are kept by the record's identity, so the seed
        methods' simulations of one run share its track)."""
        return self._record

    @cached_property
    def _record(self) -> Record:
        return record_of(self.run_id, self.t, self.phi, self.geometry)


@dataclass(frozen=True)
class Peaks:
    """Extrema of a decay (both signs) and the two envelopes fitted to their magnitudes.

    ``offset`` the midline (rad); ``times`` (s), ``amplitudes`` |peak − offset| (rad).
    Exponential envelope A = C·e^{−K·t} (log-decrement); linear A = A₀ − r·t, the envelope
    of pure dry friction (r = 4τ_c/(k·T) rad/s: 4τ_c/k per cycle of period T).
    """

    offset: float
    times: np.ndarray
    amplitudes: np.ndarray
    exp_c: float
    exp_k: float
    exp_k_std: float
    half_period: float
    half_period_std: float
    lin_a0: float
    lin_rate: float
    sse_exp: float
    sse_lin: float

    @property
    def decays_linearly(self) -> bool:
        """True when a straight line fits the peak magnitudes better than an exponential."""
        return self.times.size >= 4 and self.sse_lin < self.sse_exp

    def to_json(self) -> dict:
        """{offset, times, amplitudes, exponential {c, decay_rate}, linear {...}, ...}."""
        return {
            "offset": float(self.offset),
            "times": [float(x) for x in self.times],
            "amplitudes": [float(x) for x in self.amplitudes],
            "exponential": {"c": float(self.exp_c), "decay_rate": float(self.exp_k)},
            "linear": {"a0": float(self.lin_a0), "rate_per_s": float(self.lin_rate)},
            "sse_exponential": float(self.sse_exp),
            "sse_linear": float(self.sse_lin),
            "decays_linearly": bool(self.decays_linearly),
        }


def noise_level(phi: np.ndarray) -> float:
    """Sample noise (rad, 1σ) from third differences (a smooth swing has none), ≥ 1e-9."""
    d3 = np.diff(phi, 3)
    robust = 1.4826 * float(np.median(np.abs(d3 - np.median(d3)))) / np.sqrt(20.0)
    steps = np.abs(np.diff(phi))
    quantum = float(np.min(steps[steps > 0])) if np.any(steps > 0) else 0.0
    return max(robust, quantum / np.sqrt(12.0), 1e-9)


def prepare_decay(run: PendulumRun) -> Decay:
    """The samples at and after release, with the known plant and the noise level."""
    t, phi = run.decay()
    return Decay(run.run_id, t, phi, run.geometry, noise_level(phi), run.t_release_std)


# ---- peaks ---------------------------------------------------------------------------------
def _raw_extrema(t: np.ndarray, y: np.ndarray, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """Extrema between hysteresis zero crossings, each refined by a parabola (3 samples)."""
    label = np.where(y > threshold, 1, np.where(y < -threshold, -1, 0))
    idx = np.flatnonzero(label)
    if idx.size == 0:
        return np.zeros(0), np.zeros(0)
    lab = label[idx]
    cuts = np.flatnonzero(np.diff(lab)) + 1
    times, values = [], []
    for seg in np.split(idx, cuts):
        i = seg[0] + int(np.argmax(np.abs(y[seg[0] : seg[-1] + 1])))
        if i <= 1 or i >= y.size - 2:
            continue  # the release itself, or cut off by the end of the record
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        denom = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / denom if denom != 0 else 0.0
        shift = float(np.clip(shift, -1.0, 1.0))
        dt = 0.5 * (t[i + 1] - t[i - 1])
        times.append(t[i] + shift * dt)
        values.append(y1 - 0.25 * (y0 - y2) * shift)
    return np.array(times), np.array(values)


def _line(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares line: (coef [intercept, slope], cov, sse)."""
    a = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    res = y - a @ coef
    sse = float(res @ res)
    dof = max(x.size - 2, 1)
    cov = sse / dof * np.linalg.inv(a.T @ a)
    return coef, cov, sse


def find_peaks(decay: Decay) -> Peaks:
    """Extrema of both signs and their exponential and linear envelopes.

    The midline (equilibrium angle) is the one that makes ln|peak − midline| most nearly
    linear in t; extrema within 10σ of noise (or 1 % of the swing) are ignored.
    """
    t, phi = decay.t, decay.phi
    swing = float(np.max(np.abs(phi - np.median(phi))))
    threshold = max(10 * decay.noise, 0.01 * swing)
    centre = float(np.median(phi[-max(phi.size // 5, 1) :]))
    times, values = _raw_extrema(t, phi - centre, threshold)
    if times.size < MIN_EXTREMA:
        raise ValueError(
            f"run {decay.run_id!r}: angle: got {times.size} swing extrema above "
            f"{threshold:.2g} rad, allowed: >= {MIN_EXTREMA} (no free oscillation recorded)"
        )
    values = values + centre

    def sse(c: float) -> float:
        return _line(times, np.log(np.maximum(np.abs(values - c), 1e-300)))[2]

    span = 0.5 * float(np.min(np.abs(values - centre)))
    offset = centre
    if times.size >= 4:
        offset = float(minimize_scalar(sse, bounds=(centre - span, centre + span)).x)
    amps = np.abs(values - offset)
    (ln_c, slope), cov, _ = _line(times, np.log(amps))
    exp_fit = np.exp(ln_c + slope * times)
    lin, _, sse_lin = _line(times, amps)
    spacing, cov_s, _ = _line(np.arange(times.size, dtype=float), times)
    return Peaks(
        offset=offset,
        times=times,
        amplitudes=amps,
        exp_c=float(np.exp(ln_c)),
        exp_k=float(-slope),
        exp_k_std=float(np.sqrt(cov[1, 1])),
        half_period=float(spacing[1]),
        half_period_std=float(np.sqrt(cov_s[1, 1])),
        lin_a0=float(lin[0]),
        lin_rate=float(-lin[1]),
        sse_exp=float(np.sum((amps - exp_fit) ** 2)),
        sse_lin=sse_lin,
    )
