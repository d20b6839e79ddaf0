"""The budget's arithmetic (Welch–Satterthwaite, k, ITTC rounding), declared tolerances,
and the repeat-run rules (grouping by condition, Chauvenet's criterion)."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE, RigConfigError, parse_rig
from estimation import RunData
from estimation.uncertainty import check_tolerances
from estimation.uncertainty.budget import coverage_factor, effective_dof, round_reported
from estimation.uncertainty.repeats import chauvenet, group_conditions
from estimation.uncertainty.sources import ToleranceError


def test_welch_satterthwaite_and_the_coverage_factor():
    # two equal contributions, one with ν = 4, one exact: ν_eff = (2u²)² / (u⁴/4) = 16
    assert effective_dof([1.0, 1.0], [4.0, math.inf]) == pytest.approx(16.0)
    assert effective_dof([1.0], [math.inf]) == math.inf
    assert coverage_factor(math.inf) == pytest.approx(1.960, abs=5e-4)
    assert coverage_factor(16.0) == pytest.approx(2.120, abs=5e-4)  # t table, 95 %, ν = 16
    assert coverage_factor(2.0) == pytest.approx(4.303, abs=5e-4)


@pytest.mark.parametrize(
    ("value", "expanded", "shown"),
    [
        (143.1426, 0.5312, ("143.14", "0.54")),  # U rounded up to 2 digits, value to match
        (7.96712, 0.05664, ("7.967", "0.057")),
        (241.14, 2.465, ("241.1", "2.5")),
        (20.16, 0.75, ("20.16", "0.75")),  # exactly two digits stays
        (1234.5, 99.6, ("1230", "100")),  # rounding up past a decade
    ],
)
def test_expanded_uncertainty_is_reported_to_two_significant_digits(value, expanded, shown):
    assert round_reported(value, expanded) == shown


def test_declared_tolerances_are_checked_naming_the_field():
    assert check_tolerances({"g_m_s2": 0.02}) == {"g_m_s2": 0.02}
    with pytest.raises(ToleranceError, match=r"tolerances.g_m_s2: got -1.*>= 0"):
        check_tolerances({"g_m_s2": -1})
    with pytest.raises(ToleranceError, match=r"tolerances.pulley_mass.*hung_mass_kg"):
        check_tolerances({"pulley_mass": 0.1})


def test_the_rig_file_declares_tolerances_and_refuses_a_bad_one_in_one_line():
    data = tomllib.loads(DEFAULT_RIG_FILE.read_text())
    rig = parse_rig(data)
    assert rig.tolerances is not None and rig.tolerances.declared()["hung_mass_kg"] == 0.005
    data["tolerances"]["encoder_scale_rel"] = 0.5
    with pytest.raises(RigConfigError, match=r"tolerances.encoder_scale_rel: .*0.1 \(got 0.5\)"):
        parse_rig(data)
    del data["tolerances"]
    assert parse_rig(data).tolerances is None


def _run(run_id: str, force: float) -> RunData:
    t = np.arange(0, 5, 0.1)
    return RunData(run_id, "surge", t, 0.1 * t, force, hung_mass_kg=abs(force) / 9.8)


def test_runs_at_the_same_condition_are_grouped_within_one_percent():
    runs = [_run("a", 24.5), _run("b", 44.1), _run("c", 24.6), _run("d", -24.5), _run("e", 26)]
    groups = [[runs[i].run_id for i in g] for g in group_conditions(runs)]
    assert sorted(groups) == sorted([["a", "c"], ["b"], ["d"], ["e"]])


def test_chauvenet_flags_only_the_outlying_repeat():
    speeds = [0.500, 0.502, 0.498, 0.501, 0.499, 0.500, 0.530]
    assert chauvenet(speeds) == [False] * 6 + [True]
    assert chauvenet([0.5, 0.6]) == [False, False]  # two repeats cannot say which is wrong
    assert chauvenet([0.5, 0.501, 0.499]) == [False, False, False]
