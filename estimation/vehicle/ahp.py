"""Analytic hierarchy process (Saaty): weights from pairwise judgement matrices.

A judgement matrix ``A`` (n×n, positive, reciprocal ``a_ji = 1/a_ij``) says how much more
important item i is than item j on the 1–9 scale. Its weights are the principal
eigenvector ``A·w = λ_max·w`` normalised to Σw = 1; its consistency index is
``CI = (λ_max − n)/(n − 1)`` and its consistency ratio ``CR = CI/RI(n)`` with Saaty's random
index RI. A matrix with ``CR ≥ 0.1`` is rejected. For a two-level hierarchy (criteria
weights ``a_i`` over groups of leaves with local weights ``w_ij``) the global weight of a
leaf is ``a_i·w_ij`` and the overall ratio is ``CR = Σ a_i·CI_i / Σ a_i·RI_i``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

#: Saaty's random consistency index for n = 1 … 9.
RANDOM_INDEX: tuple[float, ...] = (0.0, 0.0, 0.58, 0.90, 1.12, 1.24, 1.32, 1.41, 1.45)
#: A matrix (or hierarchy) with a consistency ratio at or above this is rejected.
MAX_CR = 0.1
#: a_ij·a_ji must be 1 within this (so 0.333 for 1/3 passes).
RECIPROCAL_TOLERANCE = 0.01


class AHPError(ValueError):
    """A judgement matrix that is malformed or too inconsistent; the message names it."""


@dataclass(frozen=True)
class Judgement:
    """One judgement matrix solved: weights (Σ = 1), λ_max, CI, RI, CR."""

    name: str
    labels: tuple[str, ...]
    weights: tuple[float, ...]
    lambda_max: float
    ci: float
    ri: float
    cr: float
    note: str = ""

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "labels": list(self.labels),
            "weights": list(self.weights),
            "lambda_max": self.lambda_max,
            "ci": self.ci,
            "ri": self.ri,
            "cr": self.cr,
            "note": self.note,
        }


@dataclass(frozen=True)
class Hierarchy:
    """A two-level hierarchy solved: global leaf weights and the overall CR."""

    criteria: Judgement
    groups: tuple[Judgement, ...]
    weights: dict[str, float]  # leaf label → global weight, Σ = 1
    cr: float

    def to_json(self) -> dict:
        return {
            "criteria": self.criteria.to_json(),
            "groups": [g.to_json() for g in self.groups],
            "weights": dict(self.weights),
            "cr": self.cr,
        }


def random_index(n: int) -> tuple[float, str]:
    """Saaty's RI for an n×n matrix, and a note when n is beyond the table (n > 9).

    Beyond the table the n = 9 value (1.45) is used: RI grows with n, so the CR reported
    is then an upper bound (conservative).
    """
    if n < 1:
        raise AHPError(f"n: {n} is not allowed; a judgement matrix has at least 1 row")
    if n <= len(RANDOM_INDEX):
        return RANDOM_INDEX[n - 1], ""
    note = (
        f"RI for n = {n} is beyond Saaty's table (n ≤ {len(RANDOM_INDEX)}); "
        f"used RI = {RANDOM_INDEX[-1]} of n = {len(RANDOM_INDEX)}, so CR is an upper bound"
    )
    return RANDOM_INDEX[-1], note


def check_matrix(matrix: object, name: str = "matrix") -> np.ndarray:
    """The matrix as a float array, or ``AHPError`` naming the matrix and the bad entry."""
    try:
        a = np.asarray(matrix, dtype=float)
    except (TypeError, ValueError):
        raise AHPError(
            f"{name}: {matrix!r} is not allowed; give a square list of lists of numbers"
        ) from None
    if a.ndim != 2 or a.shape[0] != a.shape[1] or a.shape[0] == 0:
        raise AHPError(
            f"{name}: shape {a.shape} is not allowed; a judgement matrix is square (n×n, n ≥ 1)"
        )
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            value = a[i, j]
            if not np.isfinite(value) or value <= 0:
                raise AHPError(
                    f"{name}[{i}][{j}]: {value:g} is not allowed; judgements are positive "
                    "finite numbers (1–9 or their reciprocals)"
                )
    for i in range(n):
        if abs(a[i, i] - 1.0) > RECIPROCAL_TOLERANCE:
            raise AHPError(
                f"{name}[{i}][{i}]: {a[i, i]:g} is not allowed; the diagonal is 1 "
                "(an item is as important as itself)"
            )
        for j in range(i + 1, n):
            if abs(a[i, j] * a[j, i] - 1.0) > RECIPROCAL_TOLERANCE:
                raise AHPError(
                    f"{name}[{j}][{i}]: {a[j, i]:g} is not allowed; it must be the reciprocal "
                    f"of {name}[{i}][{j}] = {a[i, j]:g}, i.e. {1.0 / a[i, j]:.6g}"
                )
    return a


def judge(
    matrix: object,
    name: str = "matrix",
    *,
    labels: Sequence[str] | None = None,
    max_cr: float | None = MAX_CR,
) -> Judgement:
    """Weights, λ_max, CI, RI and CR of one judgement matrix.

    Raises ``AHPError`` for a malformed matrix, and when ``CR ≥ max_cr`` (pass
    ``max_cr=None`` to get the numbers of an inconsistent matrix without the check).
    """
    a = check_matrix(matrix, name)
    n = a.shape[0]
    if labels is None:
        labels = [f"{name}.{i}" for i in range(n)]
    labels = tuple(str(x) for x in labels)
    if len(labels) != n:
        raise AHPError(f"{name}: {len(labels)} labels given for a {n}×{n} matrix; give {n}")
    values, vectors = np.linalg.eig(a)
    k = int(np.argmax(values.real))
    lam = float(values[k].real)
    w = np.abs(vectors[:, k].real)
    w = w / w.sum()
    ci = (lam - n) / (n - 1) if n > 1 else 0.0
    if abs(ci) < 1e-12:  # λ_max ≥ n for a positive reciprocal matrix; drop rounding noise
        ci = 0.0
    ri, note = random_index(n)
    cr = ci / ri if ri > 0 else 0.0  # n ≤ 2: a reciprocal matrix is always consistent
    if max_cr is not None and cr >= max_cr:
        raise AHPError(
            f"{name}: consistency ratio CR = {cr:.3f} (λ_max = {lam:.4f}, CI = {ci:.4f}, "
            f"RI = {ri}) is not allowed; revise the judgements until CR < {max_cr}"
        )
    return Judgement(
        name=name,
        labels=labels,
        weights=tuple(float(x) for x in w),
        lambda_max=lam,
        ci=float(ci),
        ri=float(ri),
        cr=float(cr),
        note=note,
    )


def hierarchy(
    criteria: object,
    groups: Sequence[tuple[object, Sequence[str]]],
    *,
    criteria_name: str = "criteria",
    group_names: Sequence[str] | None = None,
    max_cr: float | None = MAX_CR,
) -> Hierarchy:
    """Global weights of a two-level hierarchy.

    ``criteria`` compares the m groups; ``groups[i] = (matrix_i, leaf_labels_i)`` compares
    the leaves under criterion i. Each matrix must pass ``CR < max_cr`` on its own, and so
    must the overall ``CR = Σ a_i·CI_i / Σ a_i·RI_i``.
    """
    m = len(groups)
    names = list(group_names) if group_names is not None else [f"group{i}" for i in range(m)]
    if len(names) != m:
        raise AHPError(f"group_names: {len(names)} names for {m} groups; give {m}")
    top = judge(criteria, criteria_name, labels=names, max_cr=max_cr)
    if len(top.weights) != m:
        raise AHPError(
            f"{criteria_name}: a {len(top.weights)}×{len(top.weights)} matrix over "
            f"{m} groups is not allowed; give {m}×{m}"
        )
    solved = []
    weights: dict[str, float] = {}
    for (matrix, leaf_labels), gname, a_i in zip(groups, names, top.weights, strict=True):
        g = judge(matrix, gname, labels=leaf_labels, max_cr=max_cr)
        solved.append(g)
        for label, w in zip(g.labels, g.weights, strict=True):
            if label in weights:
                raise AHPError(f"{gname}: leaf {label!r} appears in two groups; name it once")
            weights[label] = a_i * w
    num = sum(a * g.ci for a, g in zip(top.weights, solved, strict=True))
    den = sum(a * g.ri for a, g in zip(top.weights, solved, strict=True))
    cr = num / den if den > 0 else 0.0
    if max_cr is not None and cr >= max_cr:
        raise AHPError(
            f"hierarchy: overall consistency ratio CR = Σa·CI/Σa·RI = {cr:.3f} is not allowed; "
            f"revise the judgements until CR < {max_cr}"
        )
    return Hierarchy(criteria=top, groups=tuple(solved), weights=weights, cr=float(cr))


def normalise_weights(weights: Mapping[str, float], labels: Sequence[str]) -> dict[str, float]:
    """Direct weights (no matrix) for ``labels``: positive, renormalised to Σ = 1.

    A label missing from ``weights`` is an error naming it, as is an unknown label.
    """
    unknown = sorted(set(weights) - set(labels))
    if unknown:
        raise AHPError(f"weights: {unknown[0]!r} is not allowed; allowed: {', '.join(labels)}")
    missing = [x for x in labels if x not in weights]
    if missing:
        raise AHPError(
            f"weights: {missing[0]!r} has no weight; give one for each of {', '.join(labels)}"
        )
    for label in labels:
        w = weights[label]
        if not np.isfinite(w) or w < 0:
            raise AHPError(f"weights.{label}: {w!r} is not allowed; give a weight ≥ 0")
    total = float(sum(weights[x] for x in labels))
    if total <= 0:
        raise AHPError("weights: all zero is not allowed; give at least one positive weight")
    return {x: float(weights[x]) / total for x in labels}
