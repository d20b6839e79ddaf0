"""Repeat runs: which runs were made at the same condition, how well they repeat, and
which repeat is an outlier (ITTC 7.5-02-01-01 §2.4, repeat tests; Chauvenet's criterion).

Same condition: same axis, same way of driving (hung weight or thrusters), same direction,
and loads within ``LOAD_TOLERANCE`` (relative) of each other. A weight hung again is the
same weight; 1 % is far below the steps between a campaign's loads (seed 000: ×1.8 and
more) and far above how well a load is set (to the gram), so the grouping does not hinge
on it.

The quantity compared between repeats is the run's terminal speed: the slope of a straight
line through the last third of its fitted window (m/s, rad/s), what the load produces.
Repeatability per condition: mean ± t_0.975(N−1)·s/√N.

Outliers: Chauvenet's criterion, the test ITTC 7.5-02-01-01 names for single outliers: a
repeat whose deviation |x_i − x̄|/s has a two-sided normal probability P with N·P < ½ is
flagged. With s taken over all N repeats (as ITTC describes it) no |z| can exceed
(N − 1)/√N, so the criterion can flag nothing below N = 5 (N = 4: 1.50 against the 1.53 it
needs): plan ≥ 5 repeats where an outlier must be caught. A flagged run is left in the
estimate unless the user asks to exclude it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import special

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.kind_advice import ADVICE, KindAdvice
from estimation.motion.output_error_fit import MotionFit
from estimation.report_numbers import finite_or_none

LOAD_TOLERANCE = 0.01
CHAUVENET_LIMIT = 0.5


@dataclass(frozen=True)
class Condition:
    """The repeats of one condition and their terminal speeds (m/s or rad/s)."""

    label: str
    run_ids: tuple[str, ...]
    speeds: tuple[float, ...]
    outliers: tuple[str, ...]

    @property
    def n(self) -> int:
        return len(self.run_ids)

    @property
    def mean(self) -> float:
        return float(np.mean(self.speeds))

    @property
    def std(self) -> float:
        """s, the sample standard deviation (NaN for one run)."""
        return float(np.std(self.speeds, ddof=1)) if self.n > 1 else math.nan

    @property
    def half_width(self) -> float:
        """t_0.975(N−1)·s/√N: the 95 % repeatability of the mean."""
        if self.n < 2:
            return math.nan
        return float(special.stdtrit(self.n - 1, 0.975) * self.std / math.sqrt(self.n))

    def to_json(self) -> dict[str, Any]:
        return {
            "condition": self.label,
            "runs": list(self.run_ids),
            "n": self.n,
            "terminal_speeds": list(self.speeds),
            "mean": finite_or_none(self.mean),
            "std": finite_or_none(self.std),
            "repeatability_95": finite_or_none(self.half_width),
            "outliers": list(self.outliers),
        }


@dataclass(frozen=True)
class RepeatAnalysis:
    """The conditions of a set of runs, the outliers found and whether they were left out."""

    conditions: tuple[Condition, ...]
    excluded: tuple[str, ...] = ()

    @property
    def outliers(self) -> tuple[str, ...]:
        return tuple(r for c in self.conditions for r in c.outliers)

    @property
    def repeated(self) -> bool:
        return any(c.n > 1 for c in self.conditions)

    def to_json(self) -> dict[str, Any]:
        return {
            "load_tolerance": LOAD_TOLERANCE,
            "outlier_test": "Chauvenet (N·P(|z| ≥ z_i) < 0.5; can flag only when N ≥ 5)",
            "conditions": [c.to_json() for c in self.conditions],
            "outliers": list(self.outliers),
            "excluded": list(self.excluded),
        }


def _load(run: RunData) -> float:
    return float(np.mean(run.drive_at_samples()))


def terminal_speed(run: RunData) -> float:
    """Slope of a line through the last third of the fitted window (m/s or rad/s)."""
    t, x = np.asarray(run.t), np.asarray(run.position)
    keep = (t > run.t_release) & run.window()
    t, x = t[keep], x[keep]
    if t.size < 3:
        return math.nan
    tail = t >= t[0] + (t[-1] - t[0]) * 2 / 3
    if np.count_nonzero(tail) < 2:
        return math.nan
    return float(np.polyfit(t[tail], x[tail], 1)[0])


def chauvenet(values: Sequence[float]) -> list[bool]:
    """True for each value Chauvenet's criterion rejects: N·erfc(|z|/√2) < ½ (N ≥ 3)."""
    x = np.asarray(values, dtype=float)
    n = x.size
    if n < 3 or not np.all(np.isfinite(x)):
        return [False] * n
    s = float(np.std(x, ddof=1))
    if s == 0:
        return [False] * n
    z = np.abs(x - x.mean()) / s
    return [bool(n * special.erfc(zi / math.sqrt(2)) < CHAUVENET_LIMIT) for zi in z]


def group_conditions(runs: Sequence[RunData]) -> list[list[int]]:
    """Run indices per condition (same axis, drive kind, direction; load within 1 %)."""
    keyed: dict[tuple[str, bool, float], list[int]] = {}
    for i, r in enumerate(runs):
        keyed.setdefault((r.axis, r.is_constant_drive(), math.copysign(1, _load(r))), []).append(i)
    groups: list[list[int]] = []
    for members in keyed.values():
        members = sorted(members, key=lambda i: abs(_load(runs[i])))
        current = [members[0]]
        for i in members[1:]:
            first = abs(_load(runs[current[0]]))
            if abs(abs(_load(runs[i])) - first) <= LOAD_TOLERANCE * max(first, 1e-12):
                current.append(i)
            else:
                groups.append(current)
                current = [i]
        groups.append(current)
    return [sorted(g) for g in sorted(groups, key=lambda g: (runs[g[0]].axis, _load(runs[g[0]])))]


def analyse_repeats(runs: Sequence[RunData], exclude_outliers: bool = False) -> RepeatAnalysis:
    """Conditions, repeatability and Chauvenet outliers of ``runs``; ``exclude_outliers``
    records that the flagged runs are to be left out (the caller drops them)."""
    conditions = []
    for group in group_conditions(runs):
        members = [runs[i] for i in group]
        speeds = [terminal_speed(r) for r in members]
        flagged = chauvenet(speeds)
        drive = "weight" if members[0].is_constant_drive() else "thrusters"
        unit = "N" if members[0].axis == "surge" else "N·m"
        label = f"{members[0].dof_name}, {drive}, {_load(members[0]):+.4g} {unit}"
        conditions.append(
            Condition(
                label,
                tuple(r.run_id for r in members),
                tuple(speeds),
                tuple(r.run_id for r, f in zip(members, flagged, strict=True) if f),
            )
        )
    analysis = RepeatAnalysis(tuple(conditions))
    if exclude_outliers:
        analysis = RepeatAnalysis(analysis.conditions, analysis.outliers)
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
    n = min((len(g) for g in groups), default=0)
    if n < 2:
        return {}, (
            "repeatability not evaluated: no condition was run more than once (ITTC names "
            f"run-to-run scatter the largest source in practice; {advice.repeat_runs}, ≥ 5 "
            "for Chauvenet's criterion to be able to flag an outlier)"
            if n < 2 and not any(len(g) > 1 for g in groups)
            else "repeatability not evaluated: some conditions were run only once"
        )
    values = []
    for k in range(n):
        campaign = [prepare(g[k]) for g in groups]
        refit = fit_output_error(campaign, fit.effects, start=fit.values, quantization_sigma=False)
        values.append(refit.values)
    std = np.std(np.array(values), axis=0, ddof=1) / math.sqrt(n)
    return {name: (float(s), n) for name, s in zip(fit.names, std, strict=True)}, ""
