"""Repeat free decays: which records were released at the same condition, how well their
damping repeats, and which record is an outlier (ITTC 7.5-02-01-01 §2.4; the statistics and
Chauvenet's criterion are every kind's, ``estimation.stats.repeatability``).

Same condition: one estimate already means one DOF and one setup (stiffness, known
inertia), so two free records repeat each other when their release amplitudes
A = |x(release) − x_eq| (x_eq: where the record settles, ``decay_end.centre``) agree within
``AMPLITUDE_TOLERANCE`` (relative), 2 %. Why 2 %: a nonlinear damping makes the equivalent
damping depend on the amplitude, B_e = B₁ + (8/3π)·ω·A·B₂ + (3/4)·ω²·A²·B₃, so records
released from different amplitudes differ in damping without any fault. On KVLCC2's roll
decay 21337 (bench/estimation_pins.py) the cubic drag is 31 % of B_e(5°), so
dB_e/B_e = 2·0.31·dA/A: a 2 % spread moves B_e by 1.3 %, below the 1.6 % σ of its
linear damping; a pure quadratic damping moves by the same 2 %. 2 % is still far above how
well the amplitude is read (the noise over the amplitude: 20 µm of 50 mm, 0.04 %), and a
release held against a stop or a mark repeats within it; releases by hand that scatter
more are separate conditions, each of one record (nothing compared, nothing flagged).

The quantity compared between repeats is the logarithmic decrement δ over the record's
first ``FIRST_CYCLES`` cycles: from its extrema e_k (``decay_end.extrema``, the turns the
window's end is read from), the half-cycle heights h_k = |e_k − e_{k+1}|/2 (an offset of the
equilibrium cancels) and δ = −2 × the least-squares slope of ln h_k over k (per cycle,
dimensionless; δ ≈ 2π·ζ). Damping is what repeats of a decay disagree on (a touch, a wave
left in the tank, a loose fitting) and what the estimate is least sure of; the damped period
moves by ζ²/2 only (0.05 % at ζ = 3 %) and would not show it. The first cycles are those at
the condition's amplitude (δ of a nonlinear damping changes as the swing decays) and the
best read (largest over the noise). A record with fewer than two half-cycle heights has no
δ (NaN): its condition is then not tested for outliers. Driven records are not compared.

Outliers: Chauvenet's criterion with its reading floor, every kind's
(``stats.repeatability.chauvenet``); a record's reading σ_δ is the position noise carried
through the reading of the extrema (five noise seeds of one decay: s = 0.07 % of δ).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from estimation.motion.decay_end import SWING_SIGMAS, centre, extrema
from estimation.motion.fit_memo import Recent
from estimation.motion.records import Record
from estimation.motion.terms import units_of
from estimation.stats.diagnostics import position_noise
from estimation.stats.repeatability import (
    Condition,
    RepeatAnalysis,
    chauvenet,
    within_tolerance,
)

AMPLITUDE_TOLERANCE = 0.02
FIRST_CYCLES = 3
QUANTITY = "logarithmic decrement over the first 3 cycles"
#: What a kept outlier's warning asks to look for (``stats.repeatability.outlier_warnings``).
LOOK_FOR = "that release (a touch, a wave left in the tank, a loose fitting)"
SAME_CONDITION = (
    "one dof and setup; free records whose release amplitudes |x(release) − x_eq| agree "
    "within the tolerance"
)


#: A decay estimate reads each windowed record's noise and release amplitude more than once
#: (the repeats' comparison, the next release's candidates): kept by the record's identity.
_NOISE: Recent[float] = Recent(size=8)
_AMPLITUDE: Recent[float] = Recent(size=8)


def _noise(record: Record) -> float:
    """``position_noise`` of ``record``'s positions on its own times."""

    def compute() -> float:
        t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
        return position_noise([x], [t])

    return _NOISE.get((record,), compute)


def release_amplitude(record: Record) -> float:
    """|x(release) − x_eq| (m or rad) of a record windowed from its release."""

    def compute() -> float:
        t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
        return abs(float(x[0]) - centre(t, x, _noise(record)))

    return _AMPLITUDE.get((record,), compute)


def log_decrement(record: Record) -> tuple[float, float]:
    """(δ, σ_δ) per cycle over the first ``FIRST_CYCLES`` cycles of a record windowed from its
    release (module doc); NaN with fewer than two half-cycle heights. σ_δ: the position
    noise σ carried through (each h_k read with σ/√2, ln h_k with σ/(√2·h_k))."""
    t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
    noise = _noise(record)
    _, e = extrema(t, x, SWING_SIGMAS * max(noise, 1e-300))
    h = np.abs(np.diff(e[: 2 * FIRST_CYCLES + 2])) / 2
    h = h[h > 0]
    if h.size < 2:
        return math.nan, math.nan
    k = np.arange(h.size) - (h.size - 1) / 2
    weights = k / float(np.sum(k**2))  # the least-squares slope is Σ weights·ln h_k
    slope = float(np.sum(weights * np.log(h)))
    sigma = float(np.sqrt(np.sum((weights * noise / (np.sqrt(2) * h)) ** 2)))
    return -2 * slope, 2 * sigma


def analyse_decay_repeats(
    records: Sequence[Record], dof: str, subject: str, exclude_outliers: bool = False
) -> RepeatAnalysis:
    """Conditions, repeatability of δ and Chauvenet outliers of the free ``records``
    (windowed from their release), each condition named by ``subject`` ("heave free
    decay"); ``exclude_outliers`` records that the flagged ones are left out (the caller
    drops them)."""
    free = [r for r in records if r.drive is None]
    amplitudes = [release_amplitude(r) for r in free]
    position = units_of(dof, ())["position"]
    conditions = []
    for group in within_tolerance(amplitudes, AMPLITUDE_TOLERANCE):
        group = sorted(group)
        members = [free[i] for i in group]
        read = [log_decrement(r) for r in members]
        values = [v for v, _ in read]
        flagged = chauvenet(values, [sigma for _, sigma in read])
        released = f"{amplitudes[group[0]]:.4g} {position}"
        conditions.append(
            Condition(
                f"{subject}, released {released} from equilibrium",
                tuple(r.run_id for r in members),
                tuple(values),
                tuple(r.run_id for r, f in zip(members, flagged, strict=True) if f),
                "1",
            )
        )
    analysis = RepeatAnalysis(
        tuple(conditions),
        quantity=QUANTITY,
        same_condition=SAME_CONDITION,
        tolerance=AMPLITUDE_TOLERANCE,
    )
    return replace(analysis, excluded=analysis.outliers) if exclude_outliers else analysis
