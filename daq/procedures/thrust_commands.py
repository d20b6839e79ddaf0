"""The commands a thruster-driven drive needs: the newest thrust calibration, the layout
that turns thruster forces into a tow's force or a spin's torque, and the inverse map from
a drive to per-thruster commands (the fitted curve, or an imported table's thrust law).

Surge (tow without a weight): every thruster pushes forward with ``F = F_total / n``.
Yaw (spin): each thruster turns the vehicle with the sign ``ThrusterPort.yaw_signs()``
gives it, at the rig file's ``yaw_lever_arm_m``; a pure torque τ asks every thruster for
``F = τ / (n·L)`` with the sign of its side, so the surge forces cancel. Reverse-running
thrusters get the larger reverse command. Pure functions: no device is touched.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from daq.procedures.params import ParameterError
from daq.store import Store
from daq.vocabulary import DRIVE_FIELD
from thrusters.settings import ThrusterPort

if TYPE_CHECKING:
    from estimation.thrust.law import ThrustLaw


def latest_calibration(store: Store) -> dict[str, Any]:
    """The newest stored thrust calibration (``daq.calibration_catalog.latest``), measured
    (``result_id``) or imported (``calibration_import_id``; its curve and rows at its
    reference voltage, the highest it covers); ParameterError when there is none."""
    from daq.calibration_catalog import latest

    found = latest(store)
    if found is None:
        raise ParameterError(
            [
                (
                    "drive",
                    "thrusters",
                    "a thrust calibration first: run `rig calibrate-thrusters` "
                    "or `rig import-calibration FILE`",
                )
            ]
        )
    data = found["data"]
    if found["source"] == "run":
        return data | {"result_id": found["id"]}
    return {
        "fit": data["fit"],
        "table": data["reference_table"],
        "result_id": None,
        "calibration_import_id": found["id"],
    }


def _below_smallest_thrust(
    kind: str,
    drive: float,
    per_thruster: float,
    smallest: float,
    sign: float,
    gain: float,
    advice: str,
    where: str = "",
) -> ParameterError:
    """The refusal of a drive whose thrust per thruster is below the smallest one calibrated
    on that side (the curve below it is a guess inside the dead band). ``gain``: thrusters ×
    arm, from thrust per thruster to the drive."""
    name, unit = DRIVE_FIELD[kind]
    side = "forward" if sign > 0 else "reverse"
    return ParameterError(
        [
            (
                name,
                drive,
                f"|{name}| at least {smallest * gain:.3g} {unit}: {per_thruster:.3g} N per "
                f"thruster is below the smallest calibrated {side} thrust ({smallest:.3g} N"
                f"{where}); {advice}",
            )
        ]
    )


def thruster_commands(
    drive: float,
    calibration: dict[str, Any],
    thrusters: ThrusterPort,
    max_command: float,
    kind: str = "spin",
) -> tuple[list[float], float]:
    """Commands (fractions) giving ``drive`` (N for a tow, N·m for a spin) and the force per
    thruster, N, through the calibration: the fitted curve corrected by the thrusts the
    load cell measured (``CalibratedThrust``, the same the estimator rebuilds the drive
    with). Refuses (ParameterError) below the smallest calibrated thrust and beyond the
    thrusters' reach at ``max_command``."""
    from estimation.thrust.curve import CalibratedThrust, ThrustCurve

    name, unit = DRIVE_FIELD[kind]
    curve = ThrustCurve.from_json(calibration["fit"])
    calibrated = CalibratedThrust.from_table(curve, calibration.get("table", []))
    signs, arm = thrusters.thrust_layout(kind)
    count = thrusters.count
    per_thruster = drive / (count * arm)
    # A negative drive (a reverse test) turns every thruster round: each pushes |F| the
    # other way, and the side it then runs on decides which calibration applies.
    reverse = -1.0 if per_thruster < 0 else 1.0
    size = abs(per_thruster)
    commands = []
    for sign in (s * reverse for s in signs):
        # Below the smallest thrust measured on that side the curve is extrapolated into the
        # dead band, where a small error means no thrust at all: refuse rather than guess.
        measured = [
            abs(r["thrust_per_thruster_n"])
            for r in calibration.get("table", [])
            if r["command"] * sign > 0 and r["thrust_per_thruster_n"] * sign > 0
        ]
        if measured and size < min(measured):
            raise _below_smallest_thrust(
                kind, drive, size, min(measured), sign, count * arm,
                "calibrate with smaller commands (e.g. --commands 0,0.05,0.1,0.2,...)",
            )  # fmt: skip
        try:
            u = calibrated.command_for_force(sign * size)
        except ValueError as err:
            raise ParameterError([(name, drive, f"within the calibrated range: {err}")]) from None
        if abs(u) > max_command:
            reach = min(abs(float(calibrated.force(c))) for c in (max_command, -max_command))
            raise ParameterError(
                [
                    (
                        name,
                        drive,
                        f"allowed up to {reach * count * arm:.3g} {unit} with these thrusters "
                        f"(max_thruster_command {max_command:g})",
                    )
                ]
            )
        commands.append(u)
    return commands, per_thruster


def law_commands(
    drive: float,
    law: ThrustLaw,
    volts: float | None,
    thrusters: ThrusterPort,
    max_command: float,
    kind: str,
) -> tuple[list[float], float]:
    """Commands giving ``drive`` through an identified thrust law at supply ``volts`` (None:
    the law's reference voltage) and the force per thruster, N. Refuses (ParameterError)
    beyond what the thrusters deliver at that voltage within ``max_command``, and below
    the smallest thrust calibrated there (``ThrustLaw.min_force``)."""
    name, unit = DRIVE_FIELD[kind]
    signs, arm = thrusters.thrust_layout(kind)
    count = thrusters.count
    per_thruster = drive / (count * arm)
    reverse = -1.0 if per_thruster < 0 else 1.0  # a reverse test turns every thruster round
    size = abs(per_thruster)
    at = law.reference_voltage if volts is None else volts
    commands = []
    for sign in (s * reverse for s in signs):
        reach = min(abs(law.max_force(at, sign)), abs(float(law.force(sign * max_command, at))))
        if size > reach:
            raise ParameterError(
                [
                    (
                        name,
                        drive,
                        f"allowed up to {reach * count * arm:.3g} {unit} with these thrusters "
                        f"at the supply voltage now ({at:.3g} V; max_thruster_command "
                        f"{max_command:g})",
                    )
                ]
            )
        floor = law.min_force(at, sign)
        if floor is not None and 0 < size < abs(floor):
            raise _below_smallest_thrust(
                kind, drive, size, abs(floor), sign, count * arm, "calibrate smaller commands",
                where=f" at {at:.3g} V, command {law.smallest_command(sign, at):g}",
            )  # fmt: skip
        commands.append(law.command_for_force(sign * size, at).value)
    return commands, per_thruster
