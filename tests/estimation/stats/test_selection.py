"""The forward-selection routine of the tow search (estimation.stats.selection), on
a toy model: a set of effects whose criterion is a table lookup."""

from __future__ import annotations

from estimation.stats.selection import forward_selection, select_round

#: Criterion (lower is better) of each model, by its effects in the order added.
CRITERION = {(): 100.0, ("a",): 60.0, ("b",): 61.0, ("c",): 90.0, ("a", "c"): 40.0}


def _fit(current: tuple[str, ...]):
    def fit(added: tuple[str, ...], kept) -> tuple[str, ...] | None:
        return (*current, *added) if (*current, *added) in CRITERION else None

    return fit


def test_the_lowest_kept_wins_and_a_rejected_one_is_passed_over():
    judged: list[tuple[str, ...]] = []

    def judge(added, model, kept) -> bool:
        judged.append(added)
        return added != ("a",)  # the best by the criterion fails the caller's rules

    chosen = select_round([("a",), ("b",), ("c",)], _fit(()), CRITERION.__getitem__, judge)
    assert chosen == (("b",), ("b",))
    assert judged == [("a",), ("b",), ("c",)]  # in order of the criterion


def test_within_the_tolerance_the_earlier_addition_wins():
    keep_all = lambda added, model, kept: True  # noqa: E731
    additions = [("b",), ("a",)]  # b preferred: a's 1.0 lower criterion is within 2
    chosen = select_round(additions, _fit(()), CRITERION.__getitem__, keep_all, tolerance=2.0)
    assert chosen is not None and chosen[0] == ("b",)
    chosen = select_round(additions, _fit(()), CRITERION.__getitem__, keep_all)
    assert chosen is not None and chosen[0] == ("a",)


def test_predicted_trials_are_fitted_lazily_and_may_be_declined():
    fitted: list[tuple[str, ...]] = []

    def fit(added, kept):
        fitted.append(added)
        return None if kept else added  # once one is kept, the rest are not worth a fit

    chosen = select_round(
        [("a",), ("b",)],
        fit,
        CRITERION.__getitem__,
        lambda added, model, kept: True,
        predicted={("a",): 70.0, ("b",): 50.0},
    )
    assert fitted == [("b",), ("a",)]  # by the prediction, not the fitted criterion
    assert chosen == (("b",), ("b",))


def test_forward_selection_extends_until_a_round_keeps_nothing():
    rounds: list[int] = []

    def extend(current: tuple[str, ...], round_no: int) -> tuple[str, ...] | None:
        rounds.append(round_no)
        rest = [(e,) for e in "abc" if e not in current]
        chosen = select_round(
            rest,
            _fit(current),
            CRITERION.__getitem__,
            lambda added, model, kept: CRITERION[model] < CRITERION[current] - 10,
        )
        return None if chosen is None else chosen[1]

    assert forward_selection((), extend) == ("a", "c")
    assert rounds == [1, 2, 3]
