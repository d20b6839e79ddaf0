"""How well the rebuilt thruster drive matches the thrust the simulated plant produced.

A thruster-driven tow on the simulated rig (Modbus TCP, thruster pty, SQLite), with the
plant's own thrust (Σ ``Plant.thrusts_n``) read every 2 ms on the simulator's loop. The
drive per sample interval is rebuilt from the same stored calibration three ways: as the
estimator does (the outputs the controller confirmed, the run's ``thrust_steps`` event,
scaled by the recorded supply voltage), without the supply correction, and from the
modelled ramp older runs fall back on. ``--load N`` runs N busy
processes alongside, as on a shared CI machine. Prints one JSON document.
Run: .venv/bin/python bench/hil_drive_fidelity.py [--load 2] [--runs 3]
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import multiprocessing
import platform
import sys
import tempfile
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from daq.procedures.motion import run_motion_test
from daq.procedures.requests import tow_parameters
from daq.run_data import thruster_drive
from daq.session import RigSession, RigSource
from daq.store import Store
from daq.store.run_events import RunEvents
from estimation.thrust.curve import CalibratedThrust, ThrustCurve
from tests.support.hil_calibration import calibrate_for_hil, measured_thrust_n

COMMAND = 0.4  # every thruster, as calibrated
RAMP_S = 0.6  # after thrust-on: the slew-limited ramp and the lag


def _busy() -> None:
    while True:
        pass


def _plant_thrust(sim) -> tuple[float, float]:
    now = sim.clock()
    sim.plant.advance_to(now)
    return now, sum(sim.plant.thrusts_n)


def _watch_plant(session: RigSession, out: list, stop: threading.Event) -> None:
    while not stop.is_set():
        out.append(session.sim.call(_plant_thrust))
        time.sleep(0.002)


def _compare(store: Store, rig, run_id: str, plant: list) -> dict:
    run = store.get_run(run_id)
    table = store.samples(run_id)
    events = RunEvents.of(store.events(run_id))
    assert events.release is not None and events.brake is not None and events.thrust_steps
    t = table.t_mono
    t_on = events.release.t_mono
    t_off = events.brake.t_mono
    steps = [(step.t_mono, list(step.fractions)) for step in events.thrust_steps]
    calibration = store.result(run.parameters["calibration_result_id"]).data
    curve = ThrustCurve.from_json(calibration["fit"])
    measured = CalibratedThrust.from_table(curve, calibration["table"])
    commands = run.parameters["commands"]
    volts = table.channels["supply_voltage"]
    estimator = thruster_drive(measured, rig, "tow", commands, t, t_on, steps, volts)
    recorded = thruster_drive(measured, rig, "tow", commands, t, t_on, steps)
    modelled = thruster_drive(measured, rig, "tow", commands, t, t_on)
    pt, pf = np.array(plant).T
    # The plant's mean thrust over each sample interval [t_k, t_k+1).
    truth = np.array(
        [
            pf[(pt >= a) & (pt < b)].mean() if np.any((pt >= a) & (pt < b)) else np.nan
            for a, b in itertools.pairwise(t)
        ]
    )
    ramp = (t[:-1] >= t_on - 0.1) & (t[:-1] < t_on + RAMP_S) & np.isfinite(truth)
    steady = (t[:-1] >= t_on + 1.5) & (t[1:] < t_off) & np.isfinite(truth)
    # How long after its acquisition tick each later output change reached the controller.
    changed = np.array([s for s, _ in steps[1:]])
    lateness = changed - t[np.searchsorted(t, changed, side="right") - 1]

    dt = np.diff(t)

    def errors(drive: np.ndarray) -> dict:
        d = drive[:-1]
        return {
            "ramp_max_abs_n": float(np.max(np.abs(d[ramp] - truth[ramp]))),
            # Impulse the rebuilt drive is short of (−) or beyond (+) during the ramp: it
            # moves every later velocity by impulse / mass, i.e. it biases the inertia.
            "ramp_impulse_error_ns": float(np.sum((d[ramp] - truth[ramp]) * dt[ramp])),
            "steady_mean_rel": float(np.mean(d[steady] / truth[steady] - 1.0)),
        }

    return {
        "steady_thrust_n": float(np.mean(truth[steady])),
        "output_changes": len(steps),
        "max_output_change_after_tick_s": float(lateness.max()) if lateness.size else 0.0,
        "recorded_outputs_and_supply": errors(estimator),
        "recorded_outputs_no_supply_correction": errors(recorded),
        "modelled_ramp_no_supply_correction": errors(modelled),
    }


async def _bench(runs: int) -> list[dict]:
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(f"sqlite:///{Path(tmp) / 'rig.db'}")
        async with RigSession(RigSource.load(), store) as session:
            rig = session.rig
            calibration = await calibrate_for_hil(session)
            force = rig.thrusters.count * measured_thrust_n(calibration, COMMAND)
            results = []
            for _ in range(runs):
                plant: list = []
                stop = threading.Event()
                watcher = threading.Thread(target=_watch_plant, args=(session, plant, stop))
                watcher.start()
                try:
                    raw = {"force_n": round(force, 3), "drive": "thrusters", "max_time_s": 3.5}
                    outcome = await run_motion_test(session, tow_parameters(raw, rig))
                finally:
                    stop.set()
                    await asyncio.to_thread(watcher.join)
                results.append(_compare(store, rig, outcome.run_id, plant))
        store.close()
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--load", type=int, default=0, help="busy processes alongside")
    parser.add_argument("--runs", type=int, default=3, help="thruster tows to compare")
    args = parser.parse_args()
    hogs = [multiprocessing.Process(target=_busy, daemon=True) for _ in range(args.load)]
    for h in hogs:
        h.start()
    try:
        runs = asyncio.run(_bench(args.runs))
    finally:
        for h in hogs:
            h.terminate()
    doc = {
        "benchmark": "hil_drive_fidelity",
        "python": platform.python_version(),
        "cpus": multiprocessing.cpu_count(),
        "busy_processes": args.load,
        "command": COMMAND,
        "runs": runs,
    }
    print(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
