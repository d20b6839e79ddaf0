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
from daq.session import RigSource
from daq.sim.scenario import load_scenario
from daq.store import Store
from tests.support.motion_runs import completed_runs
from tests.support.simrig import rig_session

#: Slow lane: real-time runs on the simulated rig, then full estimations (minutes).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]

SCENARIO = Path(__file__).resolve().parents[2] / "fixtures/scenarios/friction-and-current.toml"


def _source() -> RigSource:
    base = RigSource.load()
    return RigSource(
        rig=base.rig,
        rig_toml=base.rig_toml,
        scenario=load_scenario(SCENARIO),
        scenario_toml=SCENARIO.read_text(),
    )


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


async def _forward_then_advised_reverse(
    tmp_path, kind: str, forward_drives: list[float], reverse_too: float, seconds: float
) -> tuple[float, dict]:
    """Forward runs, estimated alone: the ambiguity is reported with a reverse run to do.
    That reverse run and ``reverse_too`` recorded, all estimated together. Returns the
    advised reverse drive and the estimate from both ways (which must be unambiguous)."""
    with Store(f"sqlite:///{tmp_path / 'rig.db'}") as store:
        async with rig_session(_source(), store) as session:
            raw = {"max_time_s": seconds, "baseline_s": 0.5}
            forward = await completed_runs(session, kind, forward_drives, **raw)
            only_forward = run_estimation(store, forward)
            reverse_drive = _reverse_from_advice(only_forward, kind)
            backward = await completed_runs(session, kind, [reverse_drive, reverse_too], **raw)
        both = run_estimation(store, forward + backward)
    print("forward only:", _effects(only_forward), only_forward["ambiguous"])
    print("both ways:", _effects(both), both["ambiguous"], both["coefficients"])
    assert both["ambiguous"] == [] and both["reverse_test"] is None
    return reverse_drive, both


async def test_reverse_tows_separate_friction_from_a_current(tmp_path):
    reverse_drive, both = await _forward_then_advised_reverse(
        tmp_path, "tow", [24.5, 44.1, 83.3], -44.1, 5.0
    )
    assert reverse_drive == pytest.approx(-83.3)
    found = _effects(both)
    assert found["coulomb_friction"] == pytest.approx(3.0, abs=0.6)
    assert found["constant_bias"] == pytest.approx(2.0, abs=0.6)
    assert both["coefficients"]["inertia"]["value"] == pytest.approx(143.26, rel=0.1)


async def test_reverse_spins_separate_bearing_friction_from_a_current(tmp_path):
    _, both = await _forward_then_advised_reverse(
        tmp_path, "spin", [0.907, 1.361, 2.269], -1.361, 8.0
    )
    found = _effects(both)
    assert found["coulomb_friction"] == pytest.approx(0.12, abs=0.02)
    assert found["constant_bias"] == pytest.approx(0.05, abs=0.02)
