"""Measured and imported thrust calibrations as one list, newest first, each named for people
(``run fc3ab8ab``, not a result's row number); ``latest`` is the newest of either; the supply
voltage the rig recorded last is the default voltage of the thrust law, and it says so."""

from __future__ import annotations

from pathlib import Path

import pytest

from daq.calibration_catalog import calibrations, latest, measured_supply, voltage_for
from daq.calibration_law import import_calibration, law_of
from daq.sample import Quality, Sample
from estimation.thrust.calibration_import import CommandUnit, ImportSpec
from tests.store.helpers import new_run
from tests.support.shared_data import shared_file

T200 = Path(__file__).resolve().parents[2] / "fixtures" / "calibrations" / "t200-bollard.csv"
T200_SPEC = ImportSpec("PWM (µs)", "Force (Kg f)", "kgf", CommandUnit("pwm_us"), "Voltage (V)")
#: A measured calibration's table as the procedure stores it (daq.procedures.thrust_calibration).
MEASURED_TABLE = [
    {"command": u, "direction": "up", "thrust_per_thruster_n": 40.0 * u, "supply_voltage_v": 15.8}
    for u in (-0.8, -0.6, -0.4, -0.2, 0.2, 0.4, 0.6, 0.8)
]


def _measured(store) -> tuple[str, int]:
    run_id = new_run(store, kind="calibration", parameters={}, channel_names=["load_cell"])
    store.finish_run(run_id, "completed")
    return run_id, store.add_result([run_id], "calibration", {"table": MEASURED_TABLE})


def _supply_run(store, volts: float) -> str:
    run_id = new_run(store, channel_names=["tow_position", "supply_voltage"])
    samples = [
        Sample(seq, 10.0 + seq / 10, 1.7e9 + seq / 10, {"tow_position": 0.0, "supply_voltage": v})
        for seq, v in enumerate((volts + 0.3, volts))
    ]
    assert all(s.quality is Quality.OK for s in samples)
    store.add_samples(run_id, samples)
    store.finish_run(run_id, "completed")
    return run_id


def test_measured_and_imported_are_listed_together_newest_first(store):
    run_id, result_id = _measured(store)
    made = import_calibration(store, T200.read_bytes(), T200_SPEC, "t200-bollard.csv")
    listed = calibrations(store)
    assert [(c["source"], c["id"]) for c in listed] == [
        ("imported", made["id"]),
        ("run", result_id),
    ]
    imported, measured = listed
    assert imported["label"] == f"imported {made['id']} (t200-bollard.csv)"
    assert imported["voltages_v"] == [10, 12, 16, 18, 20] and imported["rows"] == 255
    assert measured["label"] == f"run {run_id[:8]}" and measured["run_ids"] == [run_id]
    assert measured["voltages_v"] == [15.8] and measured["command_range"] == [-0.8, 0.8]
    # The newest is the imported table, with its rows and the curve at its reference voltage.
    newest = latest(store)
    assert newest is not None and newest["source"] == "imported" and newest["id"] == made["id"]
    assert len(newest["data"]["table"]) == 255 and newest["data"]["reference_voltage_v"] == 20
    assert newest["data"]["fit"]["parameters"]["forward_gain"]["value"] > 0
    # The law names a measured calibration by its run, not by the result's row number.
    _, info = law_of(store, "run", result_id)
    assert info["label"] == f"run {run_id[:8]}" and info["name"] == f"calibration run {run_id[:8]}"


def test_latest_is_the_measured_one_when_it_is_newer(store):
    import_calibration(store, T200.read_bytes(), T200_SPEC, "t200-bollard.csv")
    run_id, result_id = _measured(store)
    newest = latest(store)
    assert newest is not None and (newest["source"], newest["id"]) == ("run", result_id)
    assert newest["data"]["table"] == MEASURED_TABLE and newest["run_ids"] == [run_id]


def test_no_calibration_is_none(store):
    assert calibrations(store) == [] and latest(store) is None


def test_the_default_voltage_is_the_supply_the_rig_recorded_last(store):
    made = import_calibration(store, T200.read_bytes(), T200_SPEC, "t200-bollard.csv")
    law, _ = law_of(store, "imported", made["id"])
    volts, how = voltage_for(store, law.reference_voltage, None)
    assert volts == 20 and "the calibration's reference (no supply voltage recorded" in how
    run_id = _supply_run(store, 15.6)
    supply = measured_supply(store)
    assert supply is not None and supply.run_id == run_id and supply.volts == 15.6
    volts, how = voltage_for(store, law.reference_voltage, None)
    assert volts == 15.6 and how.startswith(f"15.6 V, the supply recorded last (run {run_id[:8]}")
    assert voltage_for(store, law.reference_voltage, 12.0) == (12.0, "12 V, as given")


def test_an_imported_t200_table_keeps_its_stand_channels(store):
    path = shared_file("thrusters", "T200-16V.csv")
    made = import_calibration(store, path.read_bytes(), T200_SPEC, path.name)
    assert made["channels"] == ["current_a", "rpm", "power_w", "efficiency_n_per_w"]
    (listed,) = calibrations(store)
    assert listed["channels"] == made["channels"] and listed["voltages_v"] == [16]
    newest = latest(store)
    assert newest is not None
    full = max(newest["data"]["table"], key=lambda r: r["command"])
    assert full["current_a"] == pytest.approx(23.83) and full["power_w"] == pytest.approx(381.28)


def test_the_same_calibration_id_in_two_databases_is_two_laws(tmp_path):
    """A process that opens two databases (a test worker, a CLI run in process) must not
    answer one's calibration 1 with the other's: the law cache is per database."""
    from daq.store import Store

    with Store(f"sqlite:///{tmp_path / 'a.db'}") as a, Store(f"sqlite:///{tmp_path / 'b.db'}") as b:
        _, first = _measured(a)
        run_id = new_run(b, kind="calibration", parameters={}, channel_names=["load_cell"])
        b.finish_run(run_id, "completed")
        halved = [
            row | {"thrust_per_thruster_n": row["thrust_per_thruster_n"] / 2}
            for row in MEASURED_TABLE
        ]
        second = b.add_result([run_id], "calibration", {"table": halved})
        assert first == second  # each database's first result
        law_a, _ = law_of(a, "run", first)
        law_b, _ = law_of(b, "run", second)
        assert law_b.estimate(0.6, 15.8).value == pytest.approx(
            law_a.estimate(0.6, 15.8).value / 2, rel=1e-6
        )
