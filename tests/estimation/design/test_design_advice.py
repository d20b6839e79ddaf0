"""The estimator's advice comes from the planner's envelope: never stale, never beyond the rig.

Runs from ``tests.estimation.synth`` (scipy ``solve_ivp``, not our simulator). Issue 23's two
cases: "add a reverse tow" with a reverse tow already in the set, and 167 N proposed on a
rig whose ``max_force_n`` is 100.
"""

from __future__ import annotations

import re

import pytest

from estimation import estimate
from estimation.design.advice import different_force_advice, reverse_advice, separating_hint
from estimation.design.planning_envelope import AxisEnvelope, RigEnvelope
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set


def _rig(max_force_n: float = 100.0, reverse: bool = True) -> RigEnvelope:
    surge = AxisEnvelope("surge", max_force_n, 5.5, 5.3 if reverse else None, max_rate=1.0)
    return RigEnvelope((surge,), g=9.8)


def _forces(text: str) -> list[float]:
    """Every ``rig tow --force X`` the text asks for."""
    return [float(x) for x in re.findall(r"rig tow --force (-?[0-9.eE+-]+)", text)]


def test_different_force_is_within_the_rig_and_clearly_different():
    # seed 000's forces 4.9 … 83.3: "2× the highest" would be 167 N on a 100 N rig
    text = different_force_advice("surge", [4.9, 83.3], 0.97, _rig(100.0))
    (force,) = _forces(text)
    assert 0 < force <= 100.0
    assert all(max(force / d, d / force) >= 1.5 for d in (4.9, 83.3))
    assert "167" not in text


def test_one_force_advice_from_estimate_respects_max_force():
    runs = tow_set(seed=2, drives=(83.3,))  # 4× would be 333 N
    result = estimate(runs, search_effects=False, n_bootstrap=0, envelope=_rig(100.0))
    (warning,) = [w for w in result.warnings if "not separable from one force" in w]
    (force,) = _forces(warning)
    assert 0 < force <= 100.0 and max(force / 83.3, 83.3 / force) >= 1.5


def test_reverse_advice_is_not_stale_when_a_reverse_tow_was_recorded():
    text = reverse_advice("surge", [24.5, 83.3, -24.5], _rig(), command=None)
    assert "add a reverse tow" not in text
    assert "already go both ways" in text
    (force,) = _forces(text)  # a reverse tow clearly different from the -24.5 N one
    assert force < 0 and max(abs(force) / 24.5, 24.5 / abs(force)) >= 1.5


def test_one_way_friction_on_a_rig_without_reverse_asks_for_a_decay_not_a_reverse_tow():
    runs = tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=8)
    doc = estimate(runs, n_bootstrap=0, envelope=_rig(reverse=False)).to_json()
    assert [sorted(g) for g in doc["ambiguous"]] == [["constant_bias", "coulomb_friction"]]
    assert doc["reverse_test"] is None
    (advice,) = [a for a in doc["advice"] if "coulomb_friction" in a]
    assert "free decay" in advice and "reverse tow" not in advice.replace("no reverse tow", "")


def test_one_way_friction_names_the_reverse_tow_the_rig_can_run():
    runs = tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=8)
    doc = estimate(runs, n_bootstrap=0, envelope=_rig(100.0)).to_json()
    command = doc["reverse_test"]["command"]
    assert any(a.endswith(f"run `{command}`") for a in doc["advice"])
    (force,) = _forces(command)
    assert -100.0 <= force < 0


@pytest.mark.parametrize(("limit", "expected"), [(50.0, -50.0), (100.0, -83.3)])
def test_reverse_test_is_cut_to_the_rig(limit, expected):
    runs = tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=8)  # largest drive 83.3 N
    doc = estimate(runs, n_bootstrap=0, envelope=_rig(limit)).to_json()
    assert doc["reverse_test"]["request"]["force_n"] == pytest.approx(expected)


def test_an_effects_separating_hint_drops_the_reverse_run_once_the_set_has_one():
    hint = "a reverse tow/spin (opposite force) or a free-decay run"  # coulomb_friction's
    assert separating_hint(hint, [24.5, 83.3]) == hint
    both = separating_hint(hint, [24.5, -24.5])
    assert "reverse" not in both and "clearly different load" in both
