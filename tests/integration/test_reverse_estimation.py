"""Reverse runs separate dry friction from a constant bias, through the full chain.

simulated rig with Coulomb friction *and* a current (``fixtures/scenarios/
friction-and-current.toml``) → Modbus TCP → clock → SQLite → daq.run_data → estimation.
Forward runs alone cannot tell the two apart: the estimator says so and names the reverse
run as a command. With that reverse run recorded, both effects are identified near the
simulator's truth.
"""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from api.core.estimation_job import run_estimation
from daq.procedures.motion import run_motion_test
from daq.procedures.params import spin_parameters, tow_parameters
from daq.session import RigSession, RigSource
from daq.sim.scenario import load_scenario
from daq.store import Store

#: Slow lane: real-time runs on the simulated rig, then full estimations (minutes).
pytestmark = pytest.mark.slow

SCENARIO = Path(__file__).resolve().parents[2] / "fixtures/scenarios/friction-and-current.toml"


def _source() -> RigSource:
    base = RigSource.load()
    return RigSource(
        rig=base.rig,
        rig_toml=base.rig_toml,
        scenario=load_scenario(SCENARIO),
        scenario_toml=SCENARIO.read_text(),
    )


async def _record(session: RigSession, kind: str, drives: list[float], seconds: float) -> list:
    ids = []
    for drive in drives:
        raw = {"max_time_s": seconds, "baseline_s": 0.5}
        if kind == "tow":
            params = tow_parameters(raw | {"force_n": drive}, session.rig)
        else:
            params = spin_parameters(raw | {"torque_nm": drive}, session.rig)
        outcome = await run_motion_test(session, params)
        assert outcome.status == "completed", outcome
        ids.append(outcome.run_id)
    return ids


def _effects(result: dict) -> dict[str, float]:
    return {e["name"]: e["value"] for e in result["effects"]}


def _reverse_from_advice(result: dict, kind: str) -> float:
    """The ambiguity is reported, its advice names a runnable command: parse its drive."""
    assert ["coulomb_friction", "constant_bias"] in [sorted(g) for g in result["ambiguous"]] or [
        "constant_bias",
        "coulomb_friction",
    ] in [sorted(g) for g in result["ambiguous"]], (result["ambiguous"], result["effects"])
    suggestion = result["reverse_test"]
    assert suggestion["kind"] == kind and suggestion["route"] == f"/api/jobs/{kind}"
    assert any(f"run `{suggestion['command']}`" in a for a in result["advice"])
    words = shlex.split(suggestion["command"])
    flag = "--force" if kind == "tow" else "--torque"
    assert words[:2] == ["rig", kind] and flag in words
    drive = float(words[words.index(flag) + 1])
    assert drive < 0
    assert suggestion["request"] == {
        ("force_n" if kind == "tow" else "torque_nm"): drive,
        "drive": "weight",
    }
    return drive


async def test_reverse_tows_separate_friction_from_a_current(tmp_path):
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    async with RigSession(_source(), store) as session:
        forward = await _record(session, "tow", [24.5, 44.1, 83.3], 5.0)
        only_forward = run_estimation(store, forward)
        reverse_drive = _reverse_from_advice(only_forward, "tow")
        assert reverse_drive == pytest.approx(-83.3)
        backward = await _record(session, "tow", [reverse_drive, -44.1], 5.0)
    both = run_estimation(store, forward + backward)
    print("forward only:", _effects(only_forward), only_forward["ambiguous"])
    print("both ways:", _effects(both), both["ambiguous"], both["coefficients"])
    assert both["ambiguous"] == [] and both["reverse_test"] is None
    found = _effects(both)
    assert found["coulomb_friction"] == pytest.approx(3.0, abs=0.6)
    assert found["constant_bias"] == pytest.approx(2.0, abs=0.6)
    assert both["coefficients"]["inertia"]["value"] == pytest.approx(143.26, rel=0.1)
    store.close()


async def test_reverse_spins_separate_bearing_friction_from_a_current(tmp_path):
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    async with RigSession(_source(), store) as session:
        forward = await _record(session, "spin", [0.907, 1.361, 2.269], 8.0)
        only_forward = run_estimation(store, forward)
        reverse_drive = _reverse_from_advice(only_forward, "spin")
        backward = await _record(session, "spin", [reverse_drive, -1.361], 8.0)
    both = run_estimation(store, forward + backward)
    print("forward only:", _effects(only_forward), only_forward["ambiguous"])
    print("both ways:", _effects(both), both["ambiguous"], both["coefficients"])
    assert both["ambiguous"] == [] and both["reverse_test"] is None
    found = _effects(both)
    assert found["coulomb_friction"] == pytest.approx(0.12, abs=0.02)
    assert found["constant_bias"] == pytest.approx(0.05, abs=0.02)
    store.close()
