"""Repeat free decays (``estimation.motion.decay_repeats``): records released from one
amplitude are one condition, their logarithmic decrements compared by Chauvenet's criterion
(the tows' own, ``estimation.stats.repeatability``); a flagged record is named and kept, or
left out with ``exclude_outliers``.

The records are from scipy's solve_ivp, not our integrator (``tests.estimation.term_cases.
decay``: 143 kg body + 114 kg added, k = 5730 N/m, 3 % of critical damping, released from
0.05 m, 20 µm noise), one noise seed each.
"""

from __future__ import annotations

import math

import pytest

from estimation.axis.tow_repeats import analyse_tow_repeats
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.records import Record
from estimation.uncertainty import RecordRefits, uncertainty_budget
from tests.estimation.term_cases import decay, tow_set

ZETA = 0.03  # term_cases.decay's damping ratio


def _estimate(*physics: dict, exclude_outliers: bool = False):
    """The joint fit (no search, no bootstrap: the repeats do not depend on them) of one
    record per entry of ``physics``, records r1, r2, … each with its own noise seed."""
    records, truth = [], {}
    for seed, kw in enumerate(physics, start=1):
        t, x, truth = decay("143kg", seed, **kw)
        records.append(Record(f"r{seed}", t, x))
    result = estimate_records(
        records,
        "heave",
        known_inertia=truth["known"],
        stiffness=truth["k"],
        min_inertia=0.0,
        candidates=(),
        n_bootstrap=0,
        exclude_outliers=exclude_outliers,
    )
    return result, truth


def _outlier_warnings(result):
    return [w for w in result.warnings if "outlier among the repeats" in w]


def test_five_repeats_are_one_condition_and_flag_nothing():
    """Five noise seeds of one decay: one condition of N = 5, no outlier, no warning; each
    δ is the decay's own, 2π·ζ/√(1 − ζ²) = 0.1886, within 0.5 %."""
    result, _ = _estimate({}, {}, {}, {}, {})
    (condition,) = result.repeats.conditions
    assert condition.run_ids == ("r1", "r2", "r3", "r4", "r5")
    assert condition.outliers == () and result.repeats.excluded == ()
    assert _outlier_warnings(result) == []
    delta = 2 * math.pi * ZETA / math.sqrt(1 - ZETA**2)
    assert condition.values == pytest.approx([delta] * 5, rel=0.005)
    assert 0 < condition.half_width < 0.01 * delta


def test_a_record_with_more_damping_is_flagged_named_and_kept():
    """r3 has 30 % more linear damping: Chauvenet flags exactly r3; the warning names it, its
    δ, the group's mean and s; it stays in the fit unless asked."""
    result, _ = _estimate({}, {}, {"damping": 1.3}, {}, {})
    (condition,) = result.repeats.conditions
    assert condition.outliers == ("r3",) and result.repeats.outliers == ("r3",)
    assert result.repeats.excluded == () and "r3" in result.runs
    (warning,) = _outlier_warnings(result)
    value = condition.values[2]
    assert warning.startswith("record r3 is an outlier")
    assert f"{value:.4g}" in warning and f"{condition.mean:.4g}" in warning
    assert f"s = {condition.std:.2g}" in warning and "kept in the fit" in warning


def test_exclude_outliers_leaves_the_flagged_record_out():
    """Asked, the fit is of the other four: r3 is not among the runs, the document lists it
    as excluded, the warning says so, and the linear damping is the four's (within 0.5 % of
    the truth, which the 30 % record would pull away)."""
    result, truth = _estimate({}, {}, {"damping": 1.3}, {}, {}, exclude_outliers=True)
    assert result.runs == ("r1", "r2", "r4", "r5")
    doc = result.to_json()["repeats"]
    assert doc["excluded"] == ["r3"] and doc["outliers"] == ["r3"]
    (warning,) = _outlier_warnings(result)
    assert "left out of the fit" in warning
    assert result.coefficients["linear_damping"].value == pytest.approx(truth["b1"], rel=0.005)


def test_records_released_from_different_amplitudes_are_different_conditions():
    """Two records from 0.05 m and two from 0.035 m (30 % apart, far beyond the 2 %): two
    conditions of two; 0.0505 m (1 % off) joins the 0.05 m ones."""
    result, _ = _estimate({}, {"release": 0.035}, {}, {"release": 0.035}, {"release": 0.0505})
    groups = sorted(c.run_ids for c in result.repeats.conditions)
    assert groups == [("r1", "r3", "r5"), ("r2", "r4")]
    assert result.repeats.outliers == ()


def test_a_decay_s_repeats_document_has_a_tow_set_s_shape():
    """The faces read one shape: a decay's repeats document and a tow set's have the same
    keys, at the top and per condition."""
    result, _ = _estimate({}, {})
    decay_doc = result.to_json()["repeats"]
    tow_doc = analyse_tow_repeats(tow_set("143kg", 0)).to_json()
    assert decay_doc.keys() == tow_doc.keys()
    assert decay_doc["conditions"][0].keys() == tow_doc["conditions"][0].keys()
    assert decay_doc["quantity"] != tow_doc["quantity"]


def _random_rows(result):
    """The fit's and the repeatability's rows of the linear damping's budget."""
    rows = (
        uncertainty_budget(result, RecordRefits(result), repeats=result.repeats)
        .coefficients["linear_damping"]
        .rows
    )
    return {r.source.split(" (")[0]: r for r in rows}


def test_the_budget_takes_the_repeatability_as_a_type_a_row():
    """Five clean repeats: a repeatability row (5 campaigns of one record each, ν = 4) beside
    the fit's, the two estimating one random error, so exactly one is combined. With r3's
    30 % more damping kept in the fit the campaigns' B₁ are b₁ four times and 1.3·b₁ once:
    s/√5 = 0.3·b₁/5 (s = d/√5 for one of five off by d), above the fit's σ, and it is the
    row combined."""
    clean, _ = _estimate({}, {}, {}, {}, {})
    rows = _random_rows(clean)
    assert rows["repeatability"].dof == 4
    assert rows["repeatability"].combined != rows["fit"].combined
    flagged, truth = _estimate({}, {}, {"damping": 1.3}, {}, {})
    rows = _random_rows(flagged)
    repeat, fit = rows["repeatability"], rows["fit"]
    assert repeat.standard_uncertainty == pytest.approx(0.3 * truth["b1"] / 5, rel=0.02)
    assert repeat.combined and not fit.combined and fit.contribution == 0
