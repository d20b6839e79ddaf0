"""The reverse run the estimator suggests when friction and bias are ambiguous: its kind,
signed drive, command and job body follow from the runs estimated."""

from __future__ import annotations

import numpy as np

from estimation.axis.reverse import suggest_reverse_test
from estimation.data.run_arrays import RunData

AMBIGUOUS = [("coulomb_friction", "constant_bias")]
T = np.arange(0.0, 5.0, 0.1)


def _run(drive: float, axis: str = "surge", *, thrusters: bool = False) -> RunData:
    rebuilt = np.where(T > 1.0, drive, 0.0)  # a thruster drive: zero until the thrust goes on
    return RunData(
        run_id=f"run{drive:g}",
        axis=axis,  # type: ignore[arg-type]
        t=T,
        position=np.zeros_like(T),
        drive=rebuilt if thrusters else drive,
        t_release=1.0,
        drive_law="identified" if thrusters else None,
    )


def test_weight_driven_tows_get_the_largest_force_turned_round():
    test = suggest_reverse_test("surge", [_run(24.5), _run(83.3), _run(44.1)], AMBIGUOUS)
    assert test is not None
    assert test.command == "rig tow --force -83.3"
    assert test.to_json() == {
        "kind": "tow",
        "command": "rig tow --force -83.3",
        "route": "/api/jobs/tow",
        "request": {"force_n": -83.3, "drive": "weight"},
    }


def test_thruster_spins_get_the_smallest_torque_turned_round():
    runs = [_run(-2.0, "yaw", thrusters=True), _run(-3.5, "yaw", thrusters=True)]
    test = suggest_reverse_test("yaw", runs, AMBIGUOUS)
    assert test is not None
    assert test.command == "rig spin --torque 2 --thrusters"
    assert test.request() == {"torque_nm": 2.0, "drive": "thrusters"}


def test_no_suggestion_when_runs_go_both_ways_or_nothing_is_ambiguous():
    assert suggest_reverse_test("surge", [_run(24.5), _run(-24.5)], AMBIGUOUS) is None
    assert suggest_reverse_test("surge", [_run(24.5)], []) is None
    other = [("restoring_spring", "cubic_drag")]
    assert suggest_reverse_test("surge", [_run(24.5)], other) is None
