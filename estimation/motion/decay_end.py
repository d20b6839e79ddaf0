"""Where a free decay ends: the envelope of its extrema, read against what passivity allows.

A body released from an offset and left alone loses amplitude in every half-cycle, and with
the damping terms of the library (linear, quadratic, cubic in the velocity, dry friction:
each opposes the motion and grows with the speed or stays constant) the amplitude a half-
cycle loses,

    L_k = h_k − h_{k+1},   h_k = |e_k − e_{k+1}| / 2   (e_k: the k-th extremum),

does not grow as the amplitude falls (L = W(h)/(k·h) for the work W a half-cycle's damping
takes, with W/h non-decreasing in h for every term of the library, up to the small change
of the period a stiffening or softening restoring force brings). ``h`` is read from
consecutive opposite extrema, so an offset of the equilibrium cancels. So the record stops
being a free decay of the library's equation at the first half-cycle that

1. **gains amplitude**: L_k < −``CHANGE_SIGMAS``·σ_L (energy came in: a wave reflected from
   the tank's wall or beach, a touch, the carriage starting), or
2. **loses more than the half-cycle before it**: L_k − L_{k−1} > ``CHANGE_SIGMAS``·σ_J (energy
   was taken: the carriage stopping, a hand catching the model),

with σ_L, σ_J the envelope's own scatter (1.4826 × the median absolute deviation of the
L_k − L_{k−1} over the record: robust to the few changes it looks for), never below what
reading the extrema with the record's noise σ gives (L: three extrema with weights
(1, 2, 1)/2, √1.5·σ; J: four with weights (1, 3, 3, 1)/2, √5·σ). 5σ: one-sided
p = 3·10⁻⁷ per half-cycle, ≈ 10⁻⁴ over the few hundred half-cycles of a long record.
The window then ends at the extremum that starts the offending half-cycle.

3. **Comes to rest**: from some sample on, the record stays within ``REST_SIGMAS``·σ of where
   it ends for at least a full period (twice the median spacing of its turns). Dry friction
   holds a body where a swing ends; a free oscillation of that period cannot stay still
   that long unless its amplitude is below the noise. The window ends at the first sample
   of the rest: what follows holds only where the body was held, and fitting it makes the
   misfit jump with the swing on which the model sticks (a decay with quadratic damping and
   dry friction, 40 % of its record at rest, converged with both coefficients 20 % low;
   ending at the rest, within 0.6 %).

A gap in the record (a dropout: a step in t of more than ``GAP_STEPS`` median steps) is
not physics: a half-cycle read across it spans turns the record never saw, so its "loss"
is that of several half-cycles (a 1.2 s dropout in a 1.3 s period read as "energy taken
out", 4.9 of 20 s fitted). The envelope is read piece by piece between gaps: a turn next
to a gap is not seen (as at the record's ends), rules 1 and 2 compare only half-cycles of
one piece, and the σ's pool the pieces' jumps.

Extrema are found with hysteresis: a turn counts once the record has come back from it by
``SWING_SIGMAS``·σ (10σ: n Gaussian samples range over about ±4σ for n ≈ 10⁴, so noise
alone at rest makes no turn), and each is read by a parabola through the three samples
around it (the sampled maximum of a 27-sample period misses the true one by up to 0.7 %).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import pairwise

import numpy as np

CHANGE_SIGMAS = 5.0  # a departure of the envelope from passivity beyond this is a change
SWING_SIGMAS = 10.0  # a turn of the record counts once it has come back this many σ
MAD_TO_SIGMA = 1.4826  # σ of a normal distribution per median absolute deviation
MIN_HALF_CYCLES = 4  # fewer: no envelope to read, the whole record is kept
REST_SIGMAS = 5.0  # within this many σ of the final position: at rest (±4σ: 10⁴ samples)
GAP_STEPS = 5.0  # a step in t longer than this many median steps is a dropout, not data


@dataclass(frozen=True)
class FreeWindow:
    """The end of a free decay (s, the record's clock) and why it ends there."""

    end: float
    ended_by: str

    def to_json(self) -> dict[str, float | str]:
        """{end_time_s, ended_by}."""
        return {"end_time_s": float(self.end), "ended_by": self.ended_by}


def extrema(t: np.ndarray, x: np.ndarray, swing: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and values of the record's alternating turns, each confirmed by a return of
    ``swing`` and refined by a parabola through its three samples (a turn at the record's
    first or last sample is not seen: the motion may go on beyond it)."""
    found: list[int] = []
    hi = lo = 0
    direction = 0  # +1 looking for a maximum, −1 for a minimum, 0 not yet known
    # the walk reads Python floats (the same doubles): indexing an array sample by sample
    # made each read an object, most of the walk's time
    xs, ts = np.asarray(x, dtype=float).tolist(), np.asarray(t, dtype=float).tolist()
    for i in range(1, len(xs)):
        if xs[i] > xs[hi]:
            hi = i
        if xs[i] < xs[lo]:
            lo = i
        if direction >= 0 and xs[hi] - xs[i] >= swing:
            found.append(hi)
            direction, lo = -1, i
        elif direction <= 0 and xs[i] - xs[lo] >= swing:
            found.append(lo)
            direction, hi = 1, i
    times, values = [], []
    for i in found:
        if not 0 < i < len(xs) - 1:  # a record's first or last sample is not a seen turn
            continue
        y0, y1, y2 = xs[i - 1], xs[i], xs[i + 1]
        curve = y0 - 2 * y1 + y2
        s = min(max(0.5 * (y0 - y2) / curve, -1.0), 1.0) if curve != 0 else 0.0
        step = ts[i + 1] - ts[i] if s > 0 else ts[i] - ts[i - 1]
        times.append(ts[i] + s * step)
        values.append(y1 - 0.25 * (y0 - y2) * s)
    return np.array(times), np.array(values)


def centre(t: np.ndarray, x: np.ndarray, noise: float) -> float:
    """Where the record's last fifth oscillates about (m or rad): the mean of the midpoints
    (e_k + 2·e_{k+1} + e_{k+2})/4 of its extrema there (each cancels a linear decay of the
    envelope), or the median of the last fifth when it is at rest (within ``REST_SIGMAS``·σ
    of that median, or fewer than 3 samples). A median of a record that still oscillates is
    off by up to its amplitude, depending on where in the cycle it ends (KVLCC2 21337: 0.39°
    of a 3.9° swing). A last fifth that still moves but holds fewer than 3 extrema (a sparse
    record: 6 of 30 irregular points over four periods) is read with the record's last 3
    extrema instead: its median was 0.01 m off a 0.05 m decay, a swing then looked larger
    than the release and the release was put 0.75 s into the record."""
    tail = slice(-max(x.size // 5, 3), None)
    swing = SWING_SIGMAS * max(noise, 1e-300)
    _, e = extrema(t[tail], x[tail], swing)
    rest = float(np.median(x[tail]))
    if e.size < 3 and np.max(np.abs(x[tail] - rest)) > REST_SIGMAS * noise:
        _, e = extrema(t, x, swing)
        e = e[-3:]
    if e.size < 3:
        return rest
    return float(np.mean((e[:-2] + 2 * e[1:-1] + e[2:]) / 4))


def _scatter(values: np.ndarray, least: float) -> float:
    """Robust σ of ``values`` (MAD about the median), never below ``least``."""
    if values.size == 0:
        return least
    mad = float(np.median(np.abs(values - np.median(values))))
    return max(MAD_TO_SIGMA * mad, least)


def pieces(t: np.ndarray) -> list[slice]:
    """The record cut at its gaps (steps in t beyond ``GAP_STEPS`` median steps, module
    doc): one slice per stretch sampled without a dropout."""
    if t.size < 3:
        return [slice(0, t.size)]
    step = np.diff(t)
    cuts = np.nonzero(step > GAP_STEPS * float(np.median(step)))[0] + 1
    bounds = [0, *cuts.tolist(), t.size]
    return [slice(a, b) for a, b in pairwise(bounds)]


def free_decay_end(t: np.ndarray, x: np.ndarray, noise: float) -> FreeWindow:
    """Where the free decay in (t [s], x [m or rad]) from its release ends (module doc);
    ``noise``: the record's position σ. The record's last sample when nothing ends it.
    Gaps cut the envelope into pieces read apart (a dropout is not a change of energy)."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    swing = SWING_SIGMAS * max(noise, 1e-300)
    turns = [extrema(t[p], x[p], swing) for p in pieces(t)]
    when = np.concatenate([w for w, _ in turns])
    last = _rest(t, x, noise, when) or FreeWindow(float(t[-1]), "end of the record")
    halves = [np.abs(np.diff(e)) / 2 for _, e in turns]
    if sum(h.size for h in halves) < MIN_HALF_CYCLES:
        return last
    losses = [-np.diff(h) for h in halves]  # L_k, for k = 0 … n−2, per piece
    jumps = [np.diff(loss) for loss in losses]  # L_k − L_{k−1}, for k = 1 … n−2
    pooled = np.concatenate(jumps)
    sigma_l = max(_scatter(pooled, 0.0) / np.sqrt(2.0), np.sqrt(1.5) * noise)
    sigma_j = _scatter(pooled, np.sqrt(5.0) * noise)
    for (when_p, _), loss, jump in zip(turns, losses, jumps, strict=True):
        for k in range(loss.size):
            if loss[k] < -CHANGE_SIGMAS * sigma_l:
                why = (
                    f"the amplitude grew by {-loss[k]:.3g} in the half-cycle from "
                    f"t = {when_p[k + 1]:.3g} s ({-loss[k] / sigma_l:.1f}σ): energy came in"
                )
                return FreeWindow(float(when_p[k + 1]), why)
            if k >= 1 and jump[k - 1] > CHANGE_SIGMAS * sigma_j:
                why = (
                    f"the half-cycle from t = {when_p[k + 1]:.3g} s lost {loss[k]:.3g}, "
                    f"{jump[k - 1] / sigma_j:.1f}σ more than the one before "
                    f"({loss[k - 1]:.3g}): energy was taken out"
                )
                return FreeWindow(float(when_p[k + 1]), why)
    return last


def _rest(t: np.ndarray, x: np.ndarray, noise: float, turns: np.ndarray) -> FreeWindow | None:
    """Where the record comes to rest (rule 3 of the module doc), or None."""
    if turns.size < 2 or noise <= 0:
        return None
    period = 2.0 * float(np.median(np.diff(turns)))
    final = float(np.median(x[t >= t[-1] - period / 2]))
    moving = np.nonzero(np.abs(x - final) > REST_SIGMAS * noise)[0]
    first = int(moving[-1]) + 1 if moving.size else 0
    if first >= t.size or t[-1] - t[first] < period:
        return None
    return FreeWindow(
        float(t[first]),
        f"the body came to rest at t = {t[first]:.3g} s: it stays within {REST_SIGMAS:g}σ of "
        f"{final:.4g} for {t[-1] - t[first]:.3g} s, more than a period ({period:.3g} s)",
    )
