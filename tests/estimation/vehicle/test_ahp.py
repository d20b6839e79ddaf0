"""AHP: the seed-004 hierarchy gives its published weights; inconsistent matrices are caught."""

from __future__ import annotations

import numpy as np
import pytest

from estimation.vehicle.ahp import AHPError, check_matrix, hierarchy, judge, random_index

C1 = [[1, 3], [1 / 3, 1]]
C2 = [[1, 1 / 3, 1], [3, 1, 3], [1, 1 / 3, 1]]
C3 = [[1, 1], [1, 1]]
#: Seed 004, Eq. (12): Ds, DT, overshoot pitch, overshoot depth, recovery time T.
SEED_Y = {"Ds": 0.125, "DT": 0.125, "pitch": 0.15, "depth": 0.15, "T": 0.45}
#: A deliberately inconsistent 4×4 matrix (1 > 2, 2 > 3, 3 > 1 strongly).
INCONSISTENT = [
    [1, 5, 1 / 7, 3],
    [1 / 5, 1, 7, 1 / 3],
    [7, 1 / 7, 1, 5],
    [1 / 3, 3, 1 / 5, 1],
]


def _power_iteration(a: np.ndarray) -> tuple[np.ndarray, float]:
    """Independent check: principal eigenpair by power iteration (not numpy.eig)."""
    w = np.ones(a.shape[0]) / a.shape[0]
    for _ in range(2000):
        w = a @ w
        w = w / w.sum()
    return w, float(np.mean((a @ w) / w))


def test_seed_matrices_give_seed_weights_and_zero_inconsistency():
    for matrix, n, expected in (
        (C1, 2, [0.75, 0.25]),
        (C2, 3, [0.2, 0.6, 0.2]),
        (C3, 2, [0.5, 0.5]),
    ):
        j = judge(matrix, "C")
        assert j.lambda_max == pytest.approx(n, abs=1e-9)
        assert j.ci == pytest.approx(0.0, abs=1e-9)
        assert j.cr == pytest.approx(0.0, abs=1e-9)
        np.testing.assert_allclose(j.weights, expected, atol=1e-9)
    h = hierarchy(
        C1,
        [(C2, ["pitch", "T", "depth"]), (C3, ["Ds", "DT"])],
        criteria_name="C1",
        group_names=["C2", "C3"],
    )
    assert h.cr == pytest.approx(0.0, abs=1e-9)
    assert set(h.weights) == set(SEED_Y)
    for label, w in SEED_Y.items():
        assert h.weights[label] == pytest.approx(w, abs=1e-9)
    assert h.groups[0].ri == 0.58 and h.groups[1].ri == 0.0


def test_inconsistent_matrix_cr_matches_independent_computation_and_is_rejected():
    a = np.array(INCONSISTENT, dtype=float)
    w_ref, lam_ref = _power_iteration(a)
    ci_ref = (lam_ref - 4) / 3
    cr_ref = ci_ref / 0.90
    assert cr_ref >= 0.1  # the example really is inconsistent
    j = judge(INCONSISTENT, "M", max_cr=None)
    assert j.lambda_max == pytest.approx(lam_ref, rel=1e-6)
    assert j.cr == pytest.approx(cr_ref, rel=1e-5)
    np.testing.assert_allclose(j.weights, w_ref, atol=1e-6)
    with pytest.raises(AHPError, match=r"M: consistency ratio CR = \d"):
        judge(INCONSISTENT, "M")


def test_inconsistent_group_fails_the_hierarchy_naming_the_group():
    with pytest.raises(AHPError, match=r"^vertical: consistency ratio"):
        hierarchy(
            C1,
            [(INCONSISTENT, list("abcd")), (C3, ["e", "f"])],
            group_names=["vertical", "horizontal"],
        )


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        ([[1, 3], [0.5, 1]], r"M\[1\]\[0\]: 0.5 .* reciprocal of M\[0\]\[1\] = 3"),
        ([[1, -2], [-0.5, 1]], r"M\[0\]\[1\]: -2 .* positive"),
        ([[1, 2, 3], [0.5, 1, 1]], r"M: shape \(2, 3\) .* square"),
        ([[2, 1], [1, 1]], r"M\[0\]\[0\]: 2 .* diagonal is 1"),
        ([["a", 1], [1, 1]], "M: .* list of lists of numbers"),
    ],
)
def test_malformed_matrix_names_the_entry(matrix, message):
    with pytest.raises(AHPError, match=message):
        check_matrix(matrix, "M")


def test_one_third_typed_as_decimal_is_accepted():
    j = judge([[1, 3], [0.333, 1]], "C1")
    assert j.weights[0] == pytest.approx(0.75, abs=1e-3)


def test_random_index_beyond_the_table_is_said():
    assert random_index(3) == (0.58, "")
    ri, note = random_index(12)
    assert ri == 1.45 and "beyond Saaty's table" in note and "upper bound" in note
    # a consistent 12×12 matrix (a_ij = w_i/w_j) passes with the note attached
    w = np.arange(1, 13, dtype=float)
    j = judge(np.outer(w, 1 / w), "big")
    assert j.cr == pytest.approx(0.0, abs=1e-9) and "beyond" in j.note
    np.testing.assert_allclose(j.weights, w / w.sum(), atol=1e-9)
