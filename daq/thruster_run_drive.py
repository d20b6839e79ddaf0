"""The drive (force, N, or torque, N·m) a thruster-driven tow or spin gave, rebuilt from the
run's thrust calibration (an imported table's law, or a calibration run's curve and
measured lag) and the outputs the controller confirmed during the run
(``estimation.thrust.drive``); ``daq.run_data`` hands it to the estimators.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from daq.calibration_law import NoCalibration, at_reference_voltage, law_of
from daq.config import RigConfig
from daq.store import ResultNotFound, Store
from daq.store.run_events import RunEvents
from estimation.thrust.curve import CalibratedThrust, ThrustCurve
from estimation.thrust.drive import Steps, ThrustLayout, drive_from_steps, rebuild_drive
from estimation.thrust.law import ThrustLaw
from thrusters.settings import MAX_SLEW_INTERVAL_S


def rebuilt_thruster_drive(
    store: Store,
    rig: RigConfig,
    run_id: str,
    kind: str,
    params: dict,
    t: np.ndarray,
    steps: Steps,
    volts: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, str]:
    """The drive at the sample times ``t`` (s) of a run with these stored ``params``, from
    the thruster ``steps`` and the supply ``volts`` per sample (None: not recorded): the
    drive, ``DRIVE_DRAWS`` draws of it over the calibration's uncertainty, and how it
    was rebuilt (the law and where the thrust lag came from)."""
    law, curve, rows, response = _calibration(store, params)
    layout, lag_note = _measured_lag(thrust_layout_of(rig, kind), response)
    rebuilt = rebuild_drive(
        law, CalibratedThrust.from_table(curve, rows), layout, t, steps, volts, run_id, params
    )
    return rebuilt.drive, rebuilt.draws, f"{rebuilt.law}; {lag_note}"


def _measured_lag(layout: ThrustLayout, response: dict | None) -> tuple[ThrustLayout, str]:
    """The thrust lag a drive is rebuilt with: the one the calibration measured from its
    step responses, else the rig file's (``thrusters.time_constant_s``), and a note saying
    which."""
    if response and response.get("time_constant_s") is not None:
        tau, std = response["time_constant_s"], response["std_s"]
        note = f"thrust lag τ = {tau:.3g} ± {std:.1g} s measured by the calibration"
        return replace(layout, time_constant_s=float(tau)), note
    note = f"thrust lag τ = {layout.time_constant_s:g} s from the rig file (not measured)"
    return layout, note


def _calibration(
    store: Store, params: dict
) -> tuple[ThrustLaw | None, ThrustCurve, list[dict], dict | None]:
    """The run's calibration: an imported table (its thrust law, and the curve and rows at
    its reference voltage) or a calibration run's result (no law: one voltage, and the
    thrust lag measured from its steps, if it was)."""
    imported = params.get("calibration_import_id")
    if imported is not None:
        try:
            law, _ = law_of(store, "imported", imported)
        except NoCalibration:
            raise ValueError(f"imported calibration #{imported} is no longer stored") from None
        table = store.imported_calibration(imported).data["table"]
        curve, rows = at_reference_voltage(table, law)
        return law, curve, rows, None
    try:
        calibration = store.result(params["calibration_result_id"])
    except ResultNotFound:
        raise ValueError(
            f"calibration result #{params['calibration_result_id']} is no longer stored"
        ) from None
    data = calibration.data
    return None, ThrustCurve.from_json(data["fit"]), data.get("table", []), data.get("response")


def confirmed_steps(events: RunEvents, offset: float) -> list[tuple[float, list[float]]] | None:
    """The outputs the controller confirmed during the run, as (instant on the time base,
    fraction per thruster); each change is put mid-way between sending and the reply.
    None for runs recorded before the steps were stored."""
    if events.thrust_steps is None:
        return None
    return [(step.t_mono + offset, list(step.fractions)) for step in events.thrust_steps]


def thrust_layout_of(rig: RigConfig, kind: str) -> ThrustLayout:
    """How the rig's thrusters make the drive of a ``"tow"`` or a ``"spin"``."""
    port = rig.thruster_port()
    signs, arm = port.thrust_layout(kind)
    return ThrustLayout(signs, arm, port.time_constant_s, port.voltage_exponent)


def thruster_drive(
    curve: ThrustCurve | CalibratedThrust | ThrustLaw,
    rig: RigConfig,
    kind: str,
    commands: list[float],
    t: np.ndarray,
    t_on: float,
    steps: Steps | None = None,
    volts: np.ndarray | None = None,
) -> np.ndarray:
    """Drive of a thruster-driven tow (force, N) or spin (torque, N·m) per sample time
    ``t`` (:func:`estimation.thrust.drive.drive_from_steps`), from the ``steps`` the
    controller confirmed, or — for runs recorded before those were stored — the ramp the
    driver would have sent from ``t_on`` toward ``commands``: right only while the
    heartbeat kept time."""
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return np.zeros(0)
    if steps is None:
        steps = modelled_steps(rig, commands, t, t_on)
    return drive_from_steps(curve, thrust_layout_of(rig, kind), t, steps, volts)


def modelled_steps(
    rig: RigConfig, commands: list[float], t: np.ndarray, t_on: float
) -> list[tuple[float, list[float]]]:
    """The steps the driver sends toward ``commands`` when every heartbeat comes on its
    acquisition tick (runs recorded before the confirmed outputs were stored)."""
    before = t[t < t_on]
    previous = float(before[-1]) if before.size else t_on - MAX_SLEW_INTERVAL_S
    step_times = np.concatenate([[t_on], t[t > t_on]])
    credit = np.minimum(np.diff(np.concatenate([[previous], step_times])), MAX_SLEW_INTERVAL_S)
    ramp = np.cumsum(rig.limits.max_command_slew_per_s * credit)  # |command| at each step
    return [
        (float(at), [float(np.sign(c) * min(abs(c), reach)) for c in commands])
        for at, reach in zip(step_times, ramp, strict=True)
    ]
