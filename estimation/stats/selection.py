"""The mechanics of a forward search (``estimation.axis.effect_search`` uses them): rounds of
trials and the choice among the kept ones. What a trial must pass is the one rule set of
every record kind, ``estimation.stats.acceptance_rules``.

A *round* tries additions (one effect, or a combination) to the current model: each is
fitted, in order of a criterion (lower is better, a BIC), and judged by the caller's
rules; of the kept ones the lowest criterion wins, and those within ``tolerance`` of it
count as equal, the earliest in the order given winning. *Forward selection* repeats
rounds from a start model, each extending the last winner, until a round keeps nothing.

The searches differ in what they try and how they judge, which they pass in: the
additions, the fit (which may decline to fit one: a screened trial), the criterion, and
the judge (which records its own evidence).
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import TypeVar

Model = TypeVar("Model")
Addition = TypeVar("Addition", bound=Hashable)


def select_round(
    additions: Sequence[Addition],
    fit: Callable[[Addition, Mapping[Addition, Model]], Model | None],
    criterion: Callable[[Model], float],
    judge: Callable[[Addition, Model, Mapping[Addition, Model]], bool],
    *,
    predicted: Mapping[Addition, float] | None = None,
    tolerance: float = 0.0,
) -> tuple[Addition, Model] | None:
    """One round: the kept addition with the lowest criterion and its fit (None: none kept).

    ``additions`` in order of preference (ties go to the earlier one). With ``predicted``
    (a criterion each addition is expected to reach, e.g. from one linearised step) the
    trials are fitted lazily in that order, so ``fit`` can decline one given those
    ``kept`` so far (return None); without it every addition is fitted first and the
    fits are judged in order of their criterion. ``judge(addition, fit, kept)`` says
    whether it is kept.
    """
    position = {a: i for i, a in enumerate(additions)}
    if predicted is None:
        fits = {a: fit(a, {}) for a in additions}
        rank = {a: criterion(m) for a, m in fits.items() if m is not None}
    else:
        fits, rank = {}, dict(predicted)
    kept: dict[Addition, Model] = {}
    for addition in sorted(rank, key=lambda a: (rank[a], position[a])):
        model = fits[addition] if predicted is None else fit(addition, kept)
        if model is not None and judge(addition, model, kept):
            kept[addition] = model
    if not kept:
        return None
    lowest = min(criterion(m) for m in kept.values())
    near = [
        a for a, m in kept.items() if criterion(m) == lowest or criterion(m) - lowest < tolerance
    ]
    best = min(near, key=position.__getitem__)
    return best, kept[best]


def forward_selection(
    start: Model, extend: Callable[[Model, int], Model | None], first_round: int = 1
) -> Model:
    """Extend ``start`` round by round, numbered from ``first_round``
    (``extend(model, round_no)``: the next model, or None when the round kept nothing or
    had nothing to try); returns the last model kept."""
    current, round_no = start, first_round
    while (chosen := extend(current, round_no)) is not None:
        current, round_no = chosen, round_no + 1
    return current
