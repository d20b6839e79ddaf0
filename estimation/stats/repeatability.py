"""Repeats of one condition, how well they repeat and which is an outlier (ITTC
7.5-02-01-01 §2.4, repeat tests; Chauvenet's criterion), for every kind of record alike.

A kind states what makes two of its records the same condition and which quantity each
record determines on its own (a tow's terminal speed, ``axis.tow_repeats``; a decay's
logarithmic decrement, ``motion.decay_repeats``); the rest is here, one for all: grouping
by a size within a relative tolerance, the repeatability of each condition,
mean ± t_0.975(N−1)·s/√N, and the outlier test.

Outliers: Chauvenet's criterion, the test ITTC 7.5-02-01-01 names for single outliers: a
repeat whose deviation |x_i − x̄|/s has a two-sided normal probability P with N·P < ½ is
flagged. With s taken over all N repeats (as ITTC describes it) no |z| can exceed
(N − 1)/√N, so the criterion can flag nothing below N = 5 (N = 4: 1.50 against the 1.53 it
needs): plan ≥ 5 repeats where an outlier must be caught. A flagged repeat is left in the
estimate unless the user asks to exclude it.

The criterion alone flags a repeat in 13 % of sets of five that differ by reading noise only
(its threshold |z| ≥ 1.645 of at most 1.79 is met by chance). So each kind also gives every
value's reading σ (how well the record itself determines it: the position noise carried
through), and a value within ``READING_SIGMAS`` of its own σ of the mean is not flagged:
repeats that agree within how well they are read do not disagree.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from estimation.report_numbers import finite_or_none

Repeat = TypeVar("Repeat")

CHAUVENET_LIMIT = 0.5
#: A value within this many of its own reading σ of its condition's mean is not an outlier.
READING_SIGMAS = 3.0
OUTLIER_TEST = (
    f"Chauvenet (N·P(|z| ≥ z_i) < 0.5, and beyond {READING_SIGMAS:g} σ of the value's own "
    "reading; can flag only when N ≥ 5)"
)


@dataclass(frozen=True)
class Condition:
    """The repeats of one condition and the quantity each determines (``values``, in
    ``unit``)."""

    label: str
    run_ids: tuple[str, ...]
    values: tuple[float, ...]
    outliers: tuple[str, ...]
    unit: str = ""

    @property
    def n(self) -> int:
        return len(self.run_ids)

    @property
    def mean(self) -> float:
        return float(np.mean(self.values))

    @property
    def std(self) -> float:
        """s, the sample standard deviation (NaN for one run)."""
        return float(np.std(self.values, ddof=1)) if self.n > 1 else math.nan

    @property
    def half_width(self) -> float:
        """t_0.975(N−1)·s/√N: the 95 % repeatability of the mean."""
        if self.n < 2:
            return math.nan
        from scipy import special  # here: the service imports this module

        return float(special.stdtrit(self.n - 1, 0.975) * self.std / math.sqrt(self.n))

    def to_json(self) -> dict[str, Any]:
        return {
            "condition": self.label,
            "runs": list(self.run_ids),
            "n": self.n,
            "values": [finite_or_none(v) for v in self.values],
            "unit": self.unit,
            "mean": finite_or_none(self.mean),
            "std": finite_or_none(self.std),
            "repeatability_95": finite_or_none(self.half_width),
            "outliers": list(self.outliers),
        }


@dataclass(frozen=True)
class RepeatAnalysis:
    """The conditions of a set of runs, the outliers found and whether they were left out.
    ``quantity``: what each repeat's value is; ``same_condition``: the kind's rule, whose
    relative ``tolerance`` it states."""

    conditions: tuple[Condition, ...]
    excluded: tuple[str, ...] = ()
    quantity: str = ""
    same_condition: str = ""
    tolerance: float = math.nan

    @property
    def outliers(self) -> tuple[str, ...]:
        return tuple(r for c in self.conditions for r in c.outliers)

    @property
    def repeated(self) -> bool:
        """Whether any condition was run more than once."""
        return any(c.n > 1 for c in self.conditions)

    def to_json(self) -> dict[str, Any]:
        """Every kind's repeats document alike (docs/uncertainty.md)."""
        return {
            "quantity": self.quantity,
            "same_condition": self.same_condition,
            "tolerance": finite_or_none(self.tolerance),
            "outlier_test": OUTLIER_TEST,
            "conditions": [c.to_json() for c in self.conditions],
            "outliers": list(self.outliers),
            "excluded": list(self.excluded),
        }


def chauvenet(values: Sequence[float], reading_sigma: Sequence[float] | None = None) -> list[bool]:
    """True for each value Chauvenet's criterion rejects: N·erfc(|z|/√2) < ½ (N ≥ 3), and
    farther from the mean than ``READING_SIGMAS`` of its own ``reading_sigma`` (module doc;
    None: no floor)."""
    x = np.asarray(values, dtype=float)
    n = x.size
    if n < 3 or not np.all(np.isfinite(x)):
        return [False] * n
    s = float(np.std(x, ddof=1))
    if s == 0:
        return [False] * n
    deviation = np.abs(x - x.mean())
    # an unknown reading σ (NaN) sets no floor
    read = np.zeros(n) if reading_sigma is None else np.nan_to_num(np.asarray(reading_sigma))
    least = READING_SIGMAS * read
    from scipy import special  # here: the service imports this module

    return [
        bool(n * special.erfc(d / s / math.sqrt(2)) < CHAUVENET_LIMIT and d > f)
        for d, f in zip(deviation, least, strict=True)
    ]


def within_tolerance(sizes: Sequence[float], tolerance: float) -> list[list[int]]:
    """Indices of ``sizes`` (magnitudes: a load, an amplitude) in groups: taken from the
    smallest up, each joins the current group when within ``tolerance`` (relative) of its
    first, smallest member, else starts the next."""
    order = sorted(range(len(sizes)), key=lambda i: sizes[i])
    groups: list[list[int]] = []
    for i in order:
        if groups:
            first = sizes[groups[-1][0]]
            if abs(sizes[i] - first) <= tolerance * max(first, 1e-12):
                groups[-1].append(i)
                continue
        groups.append([i])
    return groups


def campaign_repeatability(
    groups: Sequence[Sequence[Repeat]],
    names: Sequence[str],
    refit: Callable[[list[Repeat]], np.ndarray],
) -> tuple[dict[str, tuple[float, int]], int]:
    """Each coefficient's repeatability from N repeat campaigns: campaign k takes the k-th
    repeat of every condition (``groups``) and is refitted on its own (``refit``: the
    coefficients ``names``); u = s/√N with ν = N − 1, the standard deviation of the mean of N
    campaigns (ITTC 7.5-02-01-01 §2.4). Returns ({name: (u, N)}, N); {} when N < 2 (some
    condition was run once)."""
    n = min((len(g) for g in groups if g), default=0)
    if n < 2:
        return {}, n
    values = np.array([list(refit([g[k] for g in groups if g])) for k in range(n)])
    std = np.std(values, axis=0, ddof=1) / math.sqrt(n)
    return {name: (float(u), n) for name, u in zip(names, std, strict=True)}, n


def outlier_warnings(analysis: RepeatAnalysis, noun: str, look_for: str) -> list[str]:
    """One sentence per flagged repeat (a ``noun``: "record", "run"): its value of the
    analysis's quantity, its condition's mean and s, and whether it was left out of the fit
    or kept (then what to ``look_for`` in it: "that release (a touch, …)")."""
    out = []
    for c in analysis.conditions:
        unit = f" {c.unit}" if c.unit and c.unit != "1" else ""
        for run, value in zip(c.run_ids, c.values, strict=True):
            if run not in c.outliers:
                continue
            fate = (
                "left out of the fit (exclude_outliers)"
                if run in analysis.excluded
                else f"kept in the fit: look for what differed in {look_for} and estimate "
                "without it if it is faulty"
            )
            out.append(
                f"{noun} {run} is an outlier among the repeats of '{c.label}': "
                f"{analysis.quantity} {value:.4g}{unit} against their mean {c.mean:.4g}{unit} "
                f"(s = {c.std:.2g}, N = {c.n}; Chauvenet's criterion): {fate}"
            )
    return out
