"""The screen's one-column step is lstsq's number, bit for bit (``term_separation``)."""

from __future__ import annotations

import numpy as np

from estimation.motion.term_separation import _solve_gram


def test_one_column_step_is_lstsqs_number() -> None:
    rng = np.random.default_rng(3)
    for _ in range(2000):
        g = np.array([[abs(rng.standard_normal()) * 10 ** rng.uniform(-100, 100)]])
        m = np.array([rng.standard_normal() * 10 ** rng.uniform(-100, 100)])
        want = np.linalg.lstsq(g, m, rcond=None)[0]
        assert _solve_gram(g, m, [0]).tobytes() == want.tobytes()


def test_a_zero_pivot_and_several_columns_go_to_lstsq() -> None:
    gram = np.array([[0.0, 0.0], [0.0, 2.0]])
    moment = np.array([0.0, 3.0])
    assert _solve_gram(gram, moment, [0]).tolist() == [0.0]
    gram = np.array([[4.0, 1.0], [1.0, 3.0]])
    want = np.linalg.lstsq(gram, moment, rcond=None)[0]
    assert _solve_gram(gram, moment, [0, 1]).tobytes() == want.tobytes()
    assert _solve_gram(gram, moment, []).size == 0
