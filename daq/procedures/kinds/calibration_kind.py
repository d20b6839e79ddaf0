"""The thrust calibration sweep: step the thrusters on the load cell, fit thrust vs command."""

from __future__ import annotations

from typing import TYPE_CHECKING

from daq.procedures import requests
from daq.procedures.kind_spec import KindOutcome, KindSpec
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind

if TYPE_CHECKING:
    from pathlib import Path


async def _run_calibration(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.thrust_calibration import run_thrust_calibration

    outcome, calibration = await run_thrust_calibration(
        session, params, abort=abort, progress=progress
    )
    return KindOutcome(outcome, {"calibration": calibration})


def _calibration_report(outcome: KindOutcome, folder: Path) -> list[Path]:
    from estimation.thrust.calibration_report import write_calibration_report

    return write_calibration_report(outcome.extra["calibration"], folder)


def _calibration_table(outcome: KindOutcome) -> list[str]:
    """Command, thrust per thruster and supply voltage, one row a step (none: no table)."""
    calibration = outcome.extra.get("calibration")
    if not calibration:
        return []
    lines = ["command   thrust/thruster [N]   supply [V]"]
    for row in calibration["table"]:
        supply = row["supply_voltage_v"]
        lines.append(
            f"{row['command']:+7.2f}   {row['thrust_per_thruster_n']:+15.3f}   "
            + (f"{supply:10.2f}" if supply is not None else "")
        )
    return lines


SPEC = KindSpec(
    kind=RunKind.THRUST_CALIBRATION,
    rank=40,
    label="thrust calibration sweep",
    help="Thrust calibration: step the thrusters on the load cell and fit thrust vs command.",
    request=requests.CalibrationRequest,
    run=_run_calibration,
    describe=lambda p: "thrust calibration",
    command="calibrate-thrusters",
    route="calibration",
    report=_calibration_report,
    summary=_calibration_table,
    needs=Needs(channels=("load_cell",), thrusters=True),
    acts=("mount_thrust_stand", "unmount_thrust_stand"),
    live=("load_cell", "thrusters"),
)
