"""The free-motion window of a raw recording: release, end, encoder glitches, time unit.

A recording made elsewhere starts with the carriage at rest before the brake lets go and
may end with it held by the brake; its encoder may glitch for one sample. ``find_window``
finds what to fit from the recording's own signals, preferring what was recorded:

* release: a recorded event or a given time, else the release coil's rising edge (the
  brake let go between the last sample with the coil off and the first with it on), else
  the motion onset (the first sustained departure from the baseline beyond the noise).
  Both the coil's bracket and the onset are refined by fitting the start of a released
  motion, x − x₀ = A·(s − τ(1 − e^{−s/τ})) with s = t − t_release (≈ A·s²/2τ at first),
  to the samples until the motion is well clear of the noise; then
  ``estimation.axis.release.fit_release`` refines the instant with the axis model itself.
* end: a recorded event or a given time, else the end_of_travel switch or the release
  coil dropping (brake on), else the carriage coming to rest (a trailing plateau).
* isolated single-sample spikes against the local trend are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.data.left_out import LeftOut
from estimation.stats.smoothing import running_median

#: Longest median sample step accepted as seconds (the rig samples at 10 Hz: 0.1 s).
MAX_MEDIAN_STEP_S = 1.0
#: A departure from the baseline must hold this many samples to count as motion.
ONSET_SUSTAIN = 3
#: Thresholds in units of the encoder noise (σ) and of its quantum.
NOISE_FACTOR, QUANTUM_FACTOR = 4.0, 1.5
SPIKE_NOISE_FACTOR, SPIKE_QUANTUM_FACTOR = 6.0, 1.5
#: The release refinement fits the motion until it is this many noise thresholds away
#: from the baseline  …
ONSET_SPAN = 20.0
#: … but never more than this long after the onset, s.
ONSET_FIT_MAX_S = 2.0
#: A trailing plateau this long (and ≥ 3 samples) is the carriage at rest, s.
REST_MIN_S = 0.3
#: Grid step of the release refinement, s, and the time constants M/K it tries.
ONSET_GRID_S = 0.001
ONSET_TAUS_S = tuple(np.geomspace(0.03, 300.0, 25))


@dataclass(frozen=True)
class WindowReport:
    """Which samples of a run were fitted and how that was decided."""

    t_release: float
    release_source: str
    t_end: float | None
    end_source: str
    dropped_before: int  # baseline samples at or before the release
    dropped_after: int  # hold samples after the end
    spikes_dropped: int  # isolated encoder glitches
    #: The first sample's time on the run's clock (release and end above are on it too).
    record_start: float = 0.0
    #: Samples left out because their value or time cannot be trusted (the loader's list).
    left_out: tuple[LeftOut, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """{release_time_s, end_time_s (the run's clock, e.g. the PLC's), release_from_start_s,
        end_from_release_s (times a person reads), sources, samples_dropped_*}."""
        end = None if self.t_end is None else float(self.t_end)
        return {
            "release_time_s": float(self.t_release),
            "release_source": self.release_source,
            "end_time_s": end,
            "end_source": self.end_source,
            "record_start_s": float(self.record_start),
            "release_from_start_s": float(self.t_release - self.record_start),
            "end_from_release_s": None if end is None else end - float(self.t_release),
            "samples_dropped_before": int(self.dropped_before),
            "samples_dropped_after": int(self.dropped_after),
            "spikes_dropped": int(self.spikes_dropped),
            "left_out": [gap.to_json() for gap in self.left_out],
        }


def check_time_step(t: np.ndarray, column: str = "t", where: str = "") -> None:
    """Refuse a time column whose median step is evidently not seconds (e.g. ms)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        return
    step = float(np.median(np.diff(t)))
    if step <= MAX_MEDIAN_STEP_S:
        return
    unit = "ms" if step < 1e4 else "us"
    prefix = f"{where}: " if where else ""
    raise ValueError(
        f"{prefix}column {column!r}: median step {step:g} between samples, expected seconds "
        f"(≤ {MAX_MEDIAN_STEP_S:g} s; 0.1 s at 10 Hz): it looks like {unit}; convert it to "
        f"seconds or pass --time-unit {unit} (API: time_unit={unit})"
    )


def encoder_quantum(x: np.ndarray) -> float:
    """The smallest non-zero step between successive positions (0 when none)."""
    steps = np.abs(np.diff(np.asarray(x, dtype=float)))
    steps = steps[steps > 1e-12]
    return float(steps.min()) if steps.size else 0.0


def _trend_deviation(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per interior sample, its deviation (position units) from the local second
    derivative's median trend; NaN at both ends."""
    h1, h2 = np.diff(t)[:-1], np.diff(t)[1:]
    accel = 2.0 * ((x[2:] - x[1:-1]) / h2 - (x[1:-1] - x[:-2]) / h1) / (h1 + h2)
    trend = running_median(accel, 9)
    dev = np.full(x.shape, np.nan)
    dev[1:-1] = (accel - trend) * h1 * h2 / 2.0
    return dev


def find_spikes(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Mask of isolated single-sample glitches: a sample far off the local trend whose two
    neighbours are pulled the other way (as a spike pulls them), unlike a kink (release,
    brake) or a turning point. Two passes, so a glitch next to another is found."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    spikes = np.zeros(x.shape, dtype=bool)
    quantum = encoder_quantum(x)
    for _ in range(2):
        idx = np.nonzero(~spikes)[0]
        if idx.size < 5:
            break
        dev = _trend_deviation(t[idx], x[idx])
        noise = 1.4826 * float(np.median(np.abs(dev[1:-1])))
        # one encoder step of dither at rest is no glitch
        limit = max(SPIKE_NOISE_FACTOR * noise, SPIKE_QUANTUM_FACTOR * quantum, 1e-9)
        prev, nxt = np.roll(dev, 1), np.roll(dev, -1)
        isolated = (
            (np.abs(dev) > limit)
            & (np.sign(prev) == -np.sign(dev))
            & (np.sign(nxt) == -np.sign(dev))
            & (np.abs(prev) > 0.25 * np.abs(dev))
            & (np.abs(nxt) > 0.25 * np.abs(dev))
        )
        isolated[[0, -1]] = False
        isolated &= np.isfinite(dev)
        if not isolated.any():
            break
        spikes[idx[isolated]] = True
    return spikes


def noise_threshold(x: np.ndarray) -> float:
    """Displacement that is motion, not encoder noise: max(4σ, 1.5 quanta), σ from the
    sample-to-sample scatter about a 5-sample running median."""
    x = np.asarray(x, dtype=float)
    scatter = x - running_median(x, 5)
    noise = 1.4826 * float(np.median(np.abs(scatter)))
    return max(NOISE_FACTOR * noise, QUANTUM_FACTOR * encoder_quantum(x), 1e-12)


def _onset_index(x: np.ndarray, base: float, direction: float, threshold: float) -> int | None:
    """First sample of the first sustained departure from ``base`` (None: never moved)."""
    away = (x - base) * direction if direction else np.abs(x - base)
    beyond = away > threshold
    n = beyond.size
    for i in np.nonzero(beyond)[0]:
        if i + ONSET_SUSTAIN <= n and beyond[i : i + ONSET_SUSTAIN].all():
            return int(i)
        if i + ONSET_SUSTAIN > n and beyond[i:].all():
            return int(i)
    return None


def refine_release(
    t: np.ndarray,
    x: np.ndarray,
    base: float,
    direction: float,
    low: float,
    high: float,
    threshold: float,
) -> float:
    """Release instant in [low, high] that best fits the start of a released motion,
    x − base = A·(s − τ(1 − e^{−s/τ})) with s = t − t_r ≥ 0 (τ on a grid), to the samples
    from ``low`` until the motion is ONSET_SPAN × ``threshold`` clear of the baseline (at
    least 3 samples after ``high``, at most ONSET_FIT_MAX_S)."""
    if not high > low:
        return float(low)
    y_all = (x - base) * (direction or 1.0)
    after = np.nonzero(t > high)[0]
    stop = high + ONSET_FIT_MAX_S
    if after.size:
        far = after[np.abs(y_all[after]) > ONSET_SPAN * threshold]
        last = after[min(2, after.size - 1)]
        stop = min(stop, max(float(t[far[0]]) if far.size else stop, float(t[last])))
    use = (t >= low) & (t <= stop)
    tt = t[use]
    y = y_all[use]
    grid = np.arange(low, high + ONSET_GRID_S / 2, ONSET_GRID_S)
    s = np.clip(tt[None, :] - grid[:, None], 0.0, None)  # (grid, samples)
    best_sse, best = np.inf, float(low)
    for tau in ONSET_TAUS_S:
        shape = s - tau * (-np.expm1(-s / tau))  # first-order start: ~s²/2τ, then ~s
        norm = (shape * shape).sum(1)
        gain = np.where(norm > 0, (shape * y).sum(1) / np.where(norm > 0, norm, 1.0), 0.0)
        sse = ((y[None, :] - gain[:, None] * shape) ** 2).sum(1)
        sse = np.where(gain > 0, sse, np.inf)
        k = int(np.argmin(sse))
        if sse[k] < best_sse:
            best_sse, best = float(sse[k]), float(grid[k])
    return best


def _rest_start(t: np.ndarray, x: np.ndarray, threshold: float) -> int | None:
    """Index of the first sample of a trailing plateau (carriage at rest), if one lasts."""
    off = np.nonzero(np.abs(x - x[-1]) > threshold)[0]
    if off.size == 0:
        return None
    start = int(off[-1]) + 1
    if x.size - start >= 3 and t[-1] - t[start] >= REST_MIN_S:
        return start
    return None


def _coil_edges(coil: np.ndarray | None) -> tuple[int | None, int | None]:
    """(first sample with the coil on after one with it off, first sample off after that)."""
    if coil is None:
        return None, None
    on = np.asarray(coil, dtype=float) >= 0.5
    rises = np.nonzero(on[1:] & ~on[:-1])[0]
    if rises.size == 0:
        return None, None
    rise = int(rises[0]) + 1
    falls = np.nonzero(~on[rise:])[0]
    return rise, (rise + int(falls[0]) if falls.size else None)


def find_window(
    t: np.ndarray,
    x: np.ndarray,
    *,
    direction: float = 0.0,
    release_coil: np.ndarray | None = None,
    end_switch: np.ndarray | None = None,
    t_release: float | None = None,
    release_source: str = "given",
    t_end: float | None = None,
    end_source: str = "given",
) -> tuple[np.ndarray, WindowReport, float | None]:
    """The samples to keep (spikes dropped), the window report, and the release's 1σ
    (s; None when ``t_release`` was given). ``direction``: sign of the motion (0: either).
    """
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    keep = ~find_spikes(t, x) if t.size >= 5 else np.ones(t.shape, dtype=bool)
    tk, xk = t[keep], x[keep]
    coil = None if release_coil is None else np.asarray(release_coil, dtype=float)[keep]
    switch = None if end_switch is None else np.asarray(end_switch, dtype=float)[keep]
    step = float(np.median(np.diff(tk))) if tk.size > 1 else 0.0
    threshold = noise_threshold(xk) if xk.size else 0.0
    release_std: float | None = None
    rise, fall = _coil_edges(coil)
    if t_release is None:
        base = float(np.median(xk[: min(3, xk.size)]))
        onset = _onset_index(xk, base, direction, threshold) if xk.size else None
        if rise is not None:
            low, high = float(tk[rise - 1]), float(tk[rise])
            base = float(np.median(xk[max(0, rise - 3) : rise]))
            t_release = refine_release(tk, xk, base, direction, low, high, threshold)
            release_source, release_std = "release coil", (high - low) / np.sqrt(12)
        elif onset is not None and onset > 0:
            base = float(np.median(xk[:onset]))
            low = float(tk[0])
            t_release = refine_release(tk, xk, base, direction, low, float(tk[onset]), threshold)
            release_source, release_std = "motion onset", step / np.sqrt(12)
        else:
            t_release = float(tk[0]) if tk.size else 0.0
            release_source, release_std = "first sample", step / np.sqrt(12)
    if t_end is None:
        ends = []
        if switch is not None:
            hit = np.nonzero((switch >= 0.5) & (tk > t_release))[0]
            if hit.size and hit[0] > 0:
                ends.append((float(tk[hit[0] - 1]), "end_of_travel switch"))
        if fall is not None and fall > 0:
            ends.append((float(tk[fall - 1]), "release coil off"))
        if ends:
            t_end, end_source = min(ends)
        else:
            moving = tk > t_release
            rest = _rest_start(tk[moving], xk[moving], threshold) if moving.sum() >= 3 else None
            if rest is not None:
                t_end, end_source = _before_rest(tk[moving], xk[moving], rest), "carriage at rest"
            else:
                end_source = "last sample"
    before = int(np.count_nonzero(tk <= t_release))
    after = 0 if t_end is None else int(np.count_nonzero(tk > t_end))
    report = WindowReport(
        float(t_release),
        release_source,
        t_end,
        end_source,
        before,
        after,
        int(np.count_nonzero(~keep)),
        float(t[0]) if t.size else 0.0,
    )
    return keep, report, release_std


def _before_rest(t: np.ndarray, x: np.ndarray, rest: int) -> float:
    """Time of the last free sample before the plateau starting at ``rest``: the sample
    before the plateau, or the one before that when the carriage was already braking
    there (its step less than half the previous one)."""
    last = rest - 1
    if last >= 2:
        v_last = abs(x[last] - x[last - 1]) / (t[last] - t[last - 1])
        v_prev = abs(x[last - 1] - x[last - 2]) / (t[last - 1] - t[last - 2])
        if v_last < 0.5 * v_prev:
            last -= 1
    return float(t[max(last, 0)])
