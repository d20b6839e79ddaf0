"""Estimation through the full chain, on data with effects nobody declared to the estimator.

simulated rig (scenario with an effect switched on) → Modbus TCP → acquisition clock →
SQLite → daq.run_data → estimation. The estimator is told only what an operator knows:
the hung weights and the rig file. It must name the effect, size it, correct the
coefficients and lower the error; on clean data it must name nothing.
"""

from __future__ import annotations

import pytest

from api.core.estimation_job import run_estimation
from daq.session import RigSource
from daq.sim.scenario import parse_scenario
from daq.store import Store
from tests.support.motion_runs import completed_runs
from tests.support.simrig import rig_session

#: Slow lane: real-time runs on the simulated rig, then full estimations (minutes).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]

SURGE_TRUTH = {"inertia": 143.26, "linear_damping": 20.16, "quadratic_damping": 241.14}
YAW_TRUTH = {"inertia": 7.97, "linear_damping": 0.119, "quadratic_damping": 4.12}


def _source(name: str, effects: dict[str, float]) -> RigSource:
    base = RigSource.load()
    scenario = parse_scenario({"name": name, "effects": effects})
    text = f'name = "{name}"\n[effects]\n' + "".join(f"{k} = {v}\n" for k, v in effects.items())
    return RigSource(rig=base.rig, rig_toml=base.rig_toml, scenario=scenario, scenario_toml=text)


async def _record(tmp_path, source: RigSource, kind: str, drives: list[float], seconds: float):
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    async with rig_session(source, store) as session:
        ids = await completed_runs(session, kind, drives, max_time_s=seconds, baseline_s=0.5)
    return store, ids


def _named(result: dict) -> set[str]:
    names = {e["name"] for e in result["effects"]}
    for group in result["ambiguous"]:
        names |= set(group)
    return names


def _report(label: str, result: dict, truth: dict) -> None:
    print(
        f"\n{label}: effects {[(e['name'], round(e['value'], 4)) for e in result['effects']]}"
        f" ambiguous {result['ambiguous']}"
    )
    for name, true in truth.items():
        c = result["coefficients"][name]
        print(f"  {name:<18} {c['value']:10.4f} ± {c['std']:.4f}  (truth {true})")
    print(f"  rmse before {result['rmse_before']:.3e}  after {result['rmse_after']:.3e}")
    for step in result.get("evidence", {}).get("steps", []):
        delta = "—" if step["delta_bic"] is None else f"{step['delta_bic']:8.1f}"
        print(
            f"  tried {step['effect']:<17} ΔBIC {delta}"
            f"  cv {step['cv_rmse_before']} → {step['cv_rmse_after']}"
            f"  {'kept' if step['accepted'] else step['reason']}"
        )


async def test_clean_tows_name_no_effect_and_recover_the_coefficients(tmp_path):
    store, ids = await _record(tmp_path, _source("clean", {}), "tow", [24.5, 44.1, 83.3], 5.0)
    result = run_estimation(store, ids)
    _report("clean tows", result, SURGE_TRUTH)
    assert result["axis"] == "surge" and result["effects"] == [] and result["ambiguous"] == []
    c = result["coefficients"]
    assert c["inertia"]["value"] == pytest.approx(SURGE_TRUTH["inertia"], rel=0.05)
    assert c["quadratic_damping"]["value"] == pytest.approx(
        SURGE_TRUTH["quadratic_damping"], rel=0.05
    )
    assert c["linear_damping"]["value"] == pytest.approx(SURGE_TRUTH["linear_damping"], abs=6.0)
    assert result["rmse_after"] < 1e-3  # encoder-step level: 0.1 mm counts
    assert store.results(ids[0], kind="estimation")  # stored with its runs
    store.close()


async def test_undeclared_carriage_friction_is_found_and_removed(tmp_path):
    store, ids = await _record(
        tmp_path, _source("coulomb", {"coulomb_friction_n": 3.0}), "tow", [24.5, 44.1, 83.3], 5.0
    )
    base = run_estimation(store, ids, search_effects=False)
    result = run_estimation(store, ids)
    _report("tows with 3 N carriage friction (undeclared), base model", base, SURGE_TRUTH)
    _report("… after the effect search", result, SURGE_TRUTH)
    # Tows that only move one way cannot tell friction from a constant bias: either the
    # friction is named, or both are reported as ambiguous with the experiment to run.
    assert "coulomb_friction" in _named(result)
    assert _named(result) <= {"coulomb_friction", "constant_bias"}
    effect = result["effects"][0]
    assert abs(effect["value"]) == pytest.approx(3.0, rel=0.25)
    assert result["rmse_after"] < 0.5 * base["rmse_before"]
    c_before, c_after = base["coefficients"], result["coefficients"]
    for name in ("inertia", "quadratic_damping"):
        err_before = abs(c_before[name]["value"] - SURGE_TRUTH[name])
        err_after = abs(c_after[name]["value"] - SURGE_TRUTH[name])
        assert err_after < err_before, name
    store.close()


async def test_undeclared_tether_torsion_is_found_on_spins(tmp_path):
    store, ids = await _record(
        tmp_path, _source("tether", {"spring_nm_per_rad": 0.08}), "spin", [0.907, 1.361, 2.269], 8.0
    )
    result = run_estimation(store, ids)
    _report("spins with a 0.08 N·m/rad tether (undeclared)", result, YAW_TRUTH)
    assert result["axis"] == "yaw"
    names = [e["name"] for e in result["effects"]]
    assert names == ["restoring_spring"]
    assert result["effects"][0]["value"] == pytest.approx(0.08, rel=0.25)
    assert result["rmse_after"] < result["rmse_before"]
    assert result["coefficients"]["inertia"]["value"] == pytest.approx(
        YAW_TRUTH["inertia"], rel=0.1
    )
    store.close()


async def test_clean_spins_name_no_effect(tmp_path):
    store, ids = await _record(tmp_path, _source("clean", {}), "spin", [0.907, 1.361, 2.269], 8.0)
    result = run_estimation(store, ids)
    _report("clean spins", result, YAW_TRUTH)
    assert result["axis"] == "yaw" and result["effects"] == [] and result["ambiguous"] == []
    c = result["coefficients"]
    assert c["inertia"]["value"] == pytest.approx(YAW_TRUTH["inertia"], rel=0.02)
    assert c["quadratic_damping"]["value"] == pytest.approx(
        YAW_TRUTH["quadratic_damping"], rel=0.03
    )
    store.close()
