"""Hardware in the loop on the simulated rig: weight-driven vs thruster-driven tows.

simulated rig → Modbus TCP / thruster serial pty → acquisition → SQLite → run_data (drive
from the stored thrust calibration and the recorded supply voltage, with drawn curves) →
estimation of both sets → cross-check. The estimator knows only the hung weights, the rig
file and the calibration. With the thrusters as calibrated the two sets agree; a supply
voltage that dropped since the calibration is compensated (the rig file's
``voltage_exponent``), so they still agree; once the thrusters themselves are weaker than
at the calibration (a fouled propeller), the cross-check must point at the calibration
with the right factor.
"""

from __future__ import annotations

from collections.abc import Iterable

import pytest

from api.core.crosscheck_job import crosscheck_results, crosscheck_runs
from daq.session import RigSource
from daq.sim.simtime import SimClock
from daq.store import Store
from estimation.axis.crosscheck_report import markdown
from tests.support.hil_calibration import calibrate_for_hil, measured_thrust_n
from tests.support.motion_runs import completed_runs
from tests.support.simrig import rig_session

pytestmark = [pytest.mark.slow, pytest.mark.simtime]

WEIGHT_FORCES = (24.5, 44.1, 83.3)
THRUSTER_COMMANDS = (0.2, 0.4, 0.6)
SECONDS = 3.5
WEIGHT_TORQUES = (0.907, 2.269)
SPIN_COMMANDS = (0.1, 0.2)
SPIN_SECONDS = 5.0
#: Supply voltage of the second case, V (the calibration ran at the scenario's 16 V).
LOW_SUPPLY_V = 14.0
#: Thrust of the fouled thrusters in the third case, as a fraction of what they gave.
FOULED = 0.85


def _supply(volts: float):
    def set_supply(sim) -> None:
        plant = sim.plant
        sensors = plant.scenario.sensors.model_copy(update={"supply_voltage_v": volts})
        plant.scenario = plant.scenario.model_copy(update={"sensors": sensors})

    return set_supply


def _foul_thrusters(sim) -> None:
    sim.plant.full_scale_thrust_n *= FOULED


async def _record(store: Store) -> dict[str, list[str]]:
    ids: dict[str, list[str]] = {}
    async with rig_session(RigSource.load(), store) as session:
        rig = session.rig
        calibration = await calibrate_for_hil(session)

        # Tow at forces the calibration measured (commands 0.2 and 0.4 on every thruster);
        # spin with the forward thrusters at commands 0.1 and 0.2.
        n, lever = rig.thrusters.count, rig.thrusters.yaw_lever_arm_m
        forces = [round(n * measured_thrust_n(calibration, u), 3) for u in THRUSTER_COMMANDS]
        torques = [round(n * lever * measured_thrust_n(calibration, u), 4) for u in SPIN_COMMANDS]

        async def tows(drive: str, drives: Iterable[float]) -> list[str]:
            return await completed_runs(
                session, "tow", drives, drive=drive, max_time_s=SECONDS, baseline_s=0.5
            )

        async def spins(drive: str, drives: Iterable[float]) -> list[str]:
            return await completed_runs(
                session, "spin", drives, drive=drive, max_time_s=SPIN_SECONDS, baseline_s=0.5
            )

        ids["weight"] = await tows("weight", WEIGHT_FORCES)
        ids["thrusters"] = await tows("thrusters", forces)
        ids["weight_spins"] = await spins("weight", WEIGHT_TORQUES)
        ids["thruster_spins"] = await spins("thrusters", torques)
        session.sim.call(_supply(LOW_SUPPLY_V))
        ids["thrusters_low"] = await tows("thrusters", forces)
        session.sim.call(_supply(16.0))
        session.sim.call(_foul_thrusters)
        ids["thrusters_fouled"] = await tows("thrusters", forces)
    return ids


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    store = Store(f"sqlite:///{tmp_path_factory.mktemp('hil') / 'rig.db'}")
    ids = SimClock.run(_record(store))
    yield store, ids
    store.close()


def _show(label: str, doc: dict) -> None:
    print(f"\n--- {label}")
    w, t = doc["weight_estimation"], doc["thruster_estimation"]
    for name, est in (("weight", w), ("thrusters", t)):
        effects = [(e["name"], round(e["value"], 4)) for e in est["effects"]]
        boot = est["bootstrap"] or {}
        print(f"{name}: effects {effects}, ambiguous {est['ambiguous']}, bootstrap σ {boot}")
    print(markdown_of(doc))


def markdown_of(doc: dict) -> str:
    from estimation.axis.drive_crosscheck import cross_check

    check = cross_check(
        doc["weight_estimation"],
        doc["thruster_estimation"],
        supply_voltage_v=doc["supply_voltage_v"],
    )
    return markdown(check)


def test_thrusters_as_calibrated_agree_with_the_weights(recorded, tmp_path):
    store, ids = recorded
    doc = crosscheck_runs(store, ids["weight"], ids["thrusters"], report_dir=tmp_path)
    _show("thrusters as calibrated", doc)
    assert doc["axis"] == "surge"
    assert doc["thruster_estimation"]["uncertainty"]["calibration_draws"] == 30
    for name, c in doc["coefficients"].items():
        assert abs(c["z"]) < 3, (name, c)
        # Informative, not just wide: σ_total within 15 % (K_L and K_Q trade off with a
        # small cubic drag the thruster set's search sometimes keeps; σ then says so).
        assert c["thruster"]["std"] < 0.15 * abs(c["thruster"]["value"]), (name, c)
    inertia = doc["coefficients"]["inertia"]
    assert abs(inertia["difference"]) < 0.02 * inertia["weight"]["value"], inertia
    assert not any("recalibrate" in d for d in doc["diagnosis"])
    factor = doc["common_factor"]
    assert abs(factor["k"] - 1.0) < 0.02
    assert (tmp_path / "crosscheck.png").stat().st_size > 5000
    # The same comparison from the two stored results, without fitting.
    again = crosscheck_results(store, doc["weight_result_id"], doc["thruster_result_id"])
    assert again["coefficients"] == doc["coefficients"]
    assert store.result(again["result_id"]).kind == "crosscheck"


def test_a_supply_drop_since_the_calibration_is_compensated(recorded):
    store, ids = recorded
    doc = crosscheck_runs(store, ids["weight"], ids["thrusters_low"])
    _show(f"supply dropped to {LOW_SUPPLY_V} V after the calibration", doc)
    volts = doc["supply_voltage_v"]
    assert volts["runs"] < volts["calibration"] - 1.0
    # Uncompensated, the thrusters would deliver (V_run / V_cal)^1.5 ≈ 0.82× the curve.
    for name, c in doc["coefficients"].items():
        assert abs(c["z"]) < 3, (name, c)
    assert abs(doc["common_factor"]["k"] - 1.0) < 0.02
    assert not any("recalibrate" in d for d in doc["diagnosis"])


def test_weaker_thrusters_than_at_calibration_point_at_the_calibration(recorded):
    store, ids = recorded
    doc = crosscheck_runs(store, ids["weight"], ids["thrusters_fouled"])
    _show(f"thrusters fouled to {FOULED}× their thrust after the calibration", doc)
    assert doc["verdict"] == "disagree"
    factor = doc["common_factor"]
    assert factor["significant"] and (factor["consistent"] or factor["dominant"])
    assert factor["thrust_factor"] == pytest.approx(
        FOULED, abs=max(0.03, 3 * factor["thrust_factor_std"])
    )
    volts = doc["supply_voltage_v"]
    assert "recalibrate" in doc["diagnosis"][0]
    assert f"{volts['runs']:.2f} V vs {volts['calibration']:.2f} V" in doc["diagnosis"][0]


def test_thruster_spins_agree_with_weight_spins(recorded):
    store, ids = recorded
    doc = crosscheck_runs(store, ids["weight_spins"], ids["thruster_spins"])
    _show("yaw: thruster couple as calibrated", doc)
    assert doc["axis"] == "yaw"
    for name, c in doc["coefficients"].items():
        assert abs(c["z"]) < 3, (name, c)
    assert not any("recalibrate" in d for d in doc["diagnosis"])
