"""Repeat tows and spins: which runs were made at the same condition, how well they repeat,
and which repeat is an outlier (ITTC 7.5-02-01-01 §2.4; the statistics and Chauvenet's
criterion are every kind's, ``estimation.stats.repeatability``).

Same condition: same axis, same way of driving (hung weight or thrusters), same direction,
and loads within ``LOAD_TOLERANCE`` (relative) of each other. A weight hung again is the
same weight; 1 % is far below the steps between a campaign's loads (seed 000: ×1.8 and
more) and far above how well a load is set (to the gram), so the grouping does not hinge
on it.

The quantity compared between repeats is the run's terminal speed: the slope of a straight
line through the last third of its fitted window (m/s, rad/s), what the load produces. Its
reading σ (Chauvenet's floor, ``stats.repeatability``) is the position noise σ_x carried
through that slope, σ_x/√Σ(t − t̄)²: repeats that differ by reading noise alone are not
outliers. A flagged run is left in the estimate unless the user asks to exclude it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.kind_advice import ADVICE, KindAdvice
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.terms import units_of
from estimation.stats.diagnostics import position_noise
from estimation.stats.repeatability import (
    Condition,
    RepeatAnalysis,
    campaign_repeatability,
    chauvenet,
    within_tolerance,
)

LOAD_TOLERANCE = 0.01
QUANTITY = "terminal speed"
SAME_CONDITION = "same axis, drive (weight or thrusters) and direction; loads within the tolerance"


def _load(run: RunData) -> float:
    return float(np.mean(run.drive_at_samples()))


def terminal_speed(run: RunData) -> tuple[float, float]:
    """(slope, its reading σ) of a line through the last third of the fitted window (m/s or
    rad/s; module doc); NaN with fewer than 2 samples there."""
    t, x = np.asarray(run.t, dtype=float), np.asarray(run.position, dtype=float)
    keep = (t > run.t_release) & run.window()
    t, x = t[keep], x[keep]
    if t.size < 3:
        return math.nan, math.nan
    tail = t >= t[0] + (t[-1] - t[0]) * 2 / 3
    if np.count_nonzero(tail) < 2:
        return math.nan, math.nan
    t, x = t[tail], x[tail]
    slope = float(np.polyfit(t, x, 1)[0])
    spread = float(np.sum((t - t.mean()) ** 2))
    return slope, position_noise([x], [t]) / math.sqrt(spread) if spread > 0 else math.nan


def group_conditions(runs: Sequence[RunData]) -> list[list[int]]:
    """Run indices per condition (same axis, drive kind, direction; load within 1 %)."""
    keyed: dict[tuple[str, bool, float], list[int]] = {}
    for i, r in enumerate(runs):
        keyed.setdefault((r.axis, r.is_constant_drive(), math.copysign(1, _load(r))), []).append(i)
    groups: list[list[int]] = []
    for members in keyed.values():
        loads = [abs(_load(runs[i])) for i in members]
        groups += [[members[j] for j in g] for g in within_tolerance(loads, LOAD_TOLERANCE)]
    return [sorted(g) for g in sorted(groups, key=lambda g: (runs[g[0]].axis, _load(runs[g[0]])))]


def analyse_repeats(runs: Sequence[RunData], exclude_outliers: bool = False) -> RepeatAnalysis:
    """Conditions, repeatability and Chauvenet outliers of ``runs``; ``exclude_outliers``
    records that the flagged runs are to be left out (the caller drops them)."""
    conditions = []
    for group in group_conditions(runs):
        members = [runs[i] for i in group]
        read = [terminal_speed(r) for r in members]
        speeds = [v for v, _ in read]
        flagged = chauvenet(speeds, [sigma for _, sigma in read])
        drive = "weight" if members[0].is_constant_drive() else "thrusters"
        unit = "N" if members[0].axis == "surge" else "N·m"
        label = f"{members[0].dof_name}, {drive}, {_load(members[0]):+.4g} {unit}"
        conditions.append(
            Condition(
                label,
                tuple(r.run_id for r in members),
                tuple(speeds),
                tuple(r.run_id for r, f in zip(members, flagged, strict=True) if f),
                units_of(members[0].axis, ())["velocity"],
            )
        )
    analysis = RepeatAnalysis(
        tuple(conditions),
        quantity=QUANTITY,
        same_condition=SAME_CONDITION,
        tolerance=LOAD_TOLERANCE,
    )
    if exclude_outliers:
        analysis = replace(analysis, excluded=analysis.outliers)
    return analysis


def without_excluded(runs: Sequence[RunData], analysis: RepeatAnalysis) -> list[RunData]:
    """The runs minus those the analysis excluded."""
    return [r for r in runs if r.run_id not in analysis.excluded]


def repeat_campaign_std(
    runs: Sequence[RunData],
    fit: MotionFit,
    analysis: RepeatAnalysis,
    advice: KindAdvice = ADVICE["tow"],
) -> tuple[dict[str, tuple[float, int]], str]:
    """Repeatability of each coefficient from N repeat campaigns (``runs`` as fitted, their
    releases refined): campaign k takes the k-th
    repeat of every condition and is fitted on its own; u = s/√N with ν = N − 1 (the
    standard deviation of the mean of N campaigns, ITTC 7.5-02-01-01 §2.4).
    Returns ({name: (u, N)}, a note when it cannot be evaluated, whose advice is
    ``advice``'s: a rig's sequence, or more imported records)."""
    index = {r.run_id: r for r in runs}
    groups = [[index[i] for i in c.run_ids if i in index] for c in analysis.conditions]
    groups = [g for g in groups if g]

    def refit(campaign: list[RunData]) -> np.ndarray:
        prepared = [prepare(r) for r in campaign]
        return fit_output_error(
            prepared, fit.effects, start=fit.values, quantization_sigma=False
        ).values

    spread, n = campaign_repeatability(groups, fit.names, refit)
    if n >= 2:
        return spread, ""
    return {}, (
        "repeatability not evaluated: no condition was run more than once (ITTC names "
        f"run-to-run scatter the largest source in practice; {advice.repeat_runs}, ≥ 5 "
        "for Chauvenet's criterion to be able to flag an outlier)"
        if not any(len(g) > 1 for g in groups)
        else "repeatability not evaluated: some conditions were run only once"
    )
