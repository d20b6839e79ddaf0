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
outliers. A flagged run is named in the result's warnings and kept in the fit, or left out
of it with ``estimate(…, exclude_outliers=True)``, as a decay's (``motion.decay_repeats``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from estimation.data.run_arrays import RunData
from estimation.motion.terms import units_of
from estimation.stats.diagnostics import position_noise
from estimation.stats.repeatability import Condition, RepeatAnalysis, chauvenet, within_tolerance

LOAD_TOLERANCE = 0.01
QUANTITY = "terminal speed"
SAME_CONDITION = "same axis, drive (weight or thrusters) and direction; loads within the tolerance"
#: What a kept outlier's warning asks to look for (``stats.repeatability.outlier_warnings``).
LOOK_FOR = "that run (the load hung or commanded, the carriage's start, a wave left in the tank)"


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


def analyse_tow_repeats(runs: Sequence[RunData], exclude_outliers: bool = False) -> RepeatAnalysis:
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
