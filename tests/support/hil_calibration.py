"""The thrust calibration the hardware-in-the-loop comparisons start from, and the thrust
it measured at a command (tests/integration/test_hil_chain.py, bench/hil_drive_fidelity.py)."""

from __future__ import annotations

from daq.procedures.requests import calibration_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.session import RigSession

#: Steps up to 0.8 with 1 s to settle: the commands the comparisons drive at are measured.
HIL_CALIBRATION = {
    "commands": [0.0, 0.1, 0.2, 0.4, 0.6, 0.8],
    "settle_s": 1.0,
    "samples_per_step": 5,
    "tare_samples": 5,
}


async def calibrate_for_hil(session: RigSession) -> dict:
    """Run ``HIL_CALIBRATION`` on ``session`` (it must complete); the stored calibration
    document (``table``, ``fit``)."""
    outcome, calibration = await run_thrust_calibration(
        session, calibration_parameters(HIL_CALIBRATION, session.rig)
    )
    assert outcome.status == "completed" and calibration is not None, outcome
    return calibration


def measured_thrust_n(calibration: dict, command: float) -> float:
    """Mean thrust of one thruster the calibration measured at ``command``, N."""
    rows = [r["thrust_per_thruster_n"] for r in calibration["table"] if r["command"] == command]
    return sum(rows) / len(rows)
