"""Forward selection of effects for the tow/spin search (``estimation.axis.effect_search``); the
acceptance rule ``term_verdict`` is shared with every record's search (``estimation.motion``).

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


#: ΔBIC below −10: "very strong" evidence (posterior odds > 150:1, Kass & Raftery 1995).
BIC_THRESHOLD = 10.0
#: A kept term explains at least this many times the position noise σ (RMS).
MATERIAL_NOISE = 1.0


def term_verdict(
    term: str,
    delta_bic: float,
    explained_rms: float,
    noise: float,
    *,
    identified: bool = True,
    at_bound: bool = False,
) -> str:
    """The shared rules for one term added to a model of any record ("kept", or why not):
    identified by the data (no lost Jacobian direction), not held at its physical bound,
    ΔBIC < −``BIC_THRESHOLD``, and material against the noise floor — the residual it
    explains, √((SSE₀ − SSE₁)/n), is at least ``MATERIAL_NOISE`` × the position noise σ
    (m or rad; never against a drive or a restoring torque: on a lightly damped body every
    damping term is ~1 % of the restoring torque, docs/estimation.md)."""
    if not identified:
        return f"{term} is not identified by these records"
    if at_bound:
        return f"{term} held at its physical bound"
    if not delta_bic < -BIC_THRESHOLD:
        return f"ΔBIC {delta_bic:.1f} ≥ −{BIC_THRESHOLD:g}"
    if explained_rms < MATERIAL_NOISE * noise:
        return (
            f"explains {explained_rms:.3g} RMS, below the noise floor {noise:.3g} the fit implies"
        )
    return "kept"
