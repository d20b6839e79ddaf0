"""A thruster drive checked against the stored thrust calibration before anything moves.

The run itself turns its drive into commands through the newest calibration
(``daq.procedures.thruster_drive``) and refuses a drive beyond the thrusters' calibrated
reach; this module asks the same question when a job or a sequence is *submitted* (and a
sequence again when it starts, since a newer calibration may have been stored while it
waited), so a 70 N thruster tow is refused at once, naming the calibrated range, instead of
failing when it reaches the rig, and a bad step 3 never lets step 1 run.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from daq.calibration_law import law_of
from daq.config import RigConfig
from daq.procedures.params import ParameterError
from daq.procedures.run_kinds import KINDS
from daq.procedures.thrust_commands import latest_calibration, law_commands, thruster_commands
from daq.store import Store
from daq.vocabulary import DRIVE_FIELD, DRIVEN_KINDS

#: Trial drives scanned from the rig limit down (×0.9 each) to find the calibrated reach.
_SCAN_STEPS = 120
#: Bisection steps refining each end of the calibrated range.
_BISECT_STEPS = 30


def _commands_for(store: Store, rig: RigConfig, kind: str) -> tuple[Callable[[float], Any], str]:
    """A function turning a drive into commands exactly as the run would (raising
    ``ParameterError`` beyond the calibration), and the calibration's name."""
    calibration = latest_calibration(store)  # ParameterError (drive) when there is none
    port = rig.thruster_port()
    max_command = rig.limits.max_thruster_command
    imported = calibration.get("calibration_import_id")
    if imported is None:
        name = f"calibration run result {calibration['result_id']}"
        return (lambda d: thruster_commands(d, calibration, port, max_command, kind)), name
    law, _ = law_of(store, "imported", imported)
    name = f"imported calibration {imported} at {law.reference_voltage:.3g} V"
    return (lambda d: law_commands(d, law, None, port, max_command, kind)), name


def _accepted(commands_for: Callable[[float], Any], drive: float) -> bool:
    try:
        commands_for(drive)
    except (ParameterError, ValueError):
        return False
    return True


def _reach(commands_for: Callable[[float], Any], limit: float, sign: float) -> float | None:
    """The largest drive of ``sign`` (up to ``limit``) the calibration delivers; None when
    it delivers none."""
    ok = None
    fail = limit
    trial = limit
    for _ in range(_SCAN_STEPS):
        if _accepted(commands_for, sign * trial):
            ok = trial
            break
        fail = trial
        trial *= 0.9
    if ok is None:
        return None
    if ok == limit:
        return limit
    for _ in range(_BISECT_STEPS):
        mid = (ok + fail) / 2
        if _accepted(commands_for, sign * mid):
            ok = mid
        else:
            fail = mid
    return ok


def check_thruster_drive(params: Any, rig: RigConfig, store: Store, prefix: str = "") -> None:
    """Refuse (``ParameterError`` naming ``prefix`` + the drive field, e.g.
    ``steps[2].force_n``, with the calibrated range) a thruster-driven tow or spin the
    newest stored calibration cannot deliver; anything else passes. The range is scanned up
    to the drive's rig limit, which its request model names (``drive_limit``)."""
    if getattr(params, "drive", None) != "thrusters" or rig.thrusters is None:
        return
    kind = str(params.kind)
    name, unit = DRIVE_FIELD[kind]
    drive = float(params.load)
    try:
        commands_for, calibration = _commands_for(store, rig, kind)
        commands_for(drive)
    except ParameterError as err:
        problems = [(f"{prefix}{field}", value, allowed) for field, value, allowed in err.problems]
        if problems and problems[0][0] == f"{prefix}{name}":
            limit = type(params).drive_limit(rig)
            low = _reach(commands_for, float(limit or 1e3), -1.0)
            high = _reach(commands_for, float(limit or 1e3), 1.0)
            if low is not None and high is not None:
                field, value, allowed = problems[0]
                span = f"allowed {-low:.3g} … {high:.3g} {unit}: the thrusters' calibrated range"
                problems[0] = (field, value, f"{span} ({calibration}); {allowed}")
        raise ParameterError(problems) from None


def check_steps(steps: Iterable[Any], rig: RigConfig, store: Store) -> None:
    """Every step of a sequence against the calibration: all problems in one error, each
    named ``steps[i].field``."""
    problems: list[tuple[str, Any, str]] = []
    for i, step in enumerate(steps):
        try:
            check_thruster_drive(step, rig, store, prefix=f"steps[{i}].")
        except ParameterError as err:
            problems += err.problems
    if problems:
        raise ParameterError(problems)


def calibrated_range(rig: RigConfig, store: Store, kind: str) -> tuple[float, float] | None:
    """The signed (low, high) drive of ``kind`` the newest stored calibration delivers,
    within the rig's limit; None without thrusters or a calibration, and for a kind that has
    no drive (a pendulum's release: nothing for thrusters to deliver)."""
    if rig.thrusters is None or kind not in DRIVEN_KINDS:
        return None
    try:
        commands_for, _ = _commands_for(store, rig, kind)
    except ParameterError:
        return None
    request = KINDS[kind].request
    limit = float((request.drive_limit(rig) if request is not None else None) or 1e3)
    low, high = _reach(commands_for, limit, -1.0), _reach(commands_for, limit, 1.0)
    if low is None or high is None:
        return None
    return (-low, high)
