"""Faults during a thruster-driven tow never leave the thrusters running.

`rig tow --thrusters` runs as a real subprocess on a hardware rig file whose devices are the
simulated rig's, reached through fault-injecting proxies: a pty↔pty proxy on the thruster
serial line and a TCP proxy in front of the PLC. Each fault hits once the thrust is on; the
controller's own outputs (the emulator's) must be zero within 0.5 s, the run aborted with a
reason naming the fault, every sample acquired stored, and the CLI must exit 1 with its JSON.

One fault per way the link is lost end to end: replies missing (the host's timeouts), the
controller hearing nothing or only noise (its watchdog too), noise where replies were, the
PLC gone, the simulator killed. Replies with a bad CRC end the same way as missing ones once
the driver has counted them: that count is tested over a real pty in process
(tests/thrusters/test_thruster_driver_emulator.py, link lost after bad replies).
"""

from __future__ import annotations

import gc
import json
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from daq.procedures.requests import calibration_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.sample import Quality
from daq.session import RigSource
from daq.sim.simtime import SimClock
from daq.sim.simulated_rig import SimulatedRigThread
from daq.store import Store
from tests.procedures.conftest import QUICK_CALIBRATION, hardware_rig_file
from tests.support.cli import printed_json
from tests.support.fault_proxies import SerialFaultProxy, TcpCutProxy
from tests.support.simrig import rig_session
from tests.support.waiting import wait_until
from thrusters.driver import LINK_LOST_AFTER

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]
RIG = [sys.executable, "-m", "api.cli.main"]
#: Longest time from the fault to zero thrust at the controller.
ZERO_WITHIN_S = 0.5


@pytest.fixture(scope="module")
def calibrated_db(tmp_path_factory) -> Path:
    """A database holding one thrust calibration of the simulated rig, recorded in process
    on simulated time (tests/support/simrig.py): it is the tows' set-up, not what is tested here."""
    path = tmp_path_factory.mktemp("calibrated") / "rig.db"

    async def calibrate() -> None:
        with Store(f"sqlite:///{path}") as store:
            async with rig_session(RigSource.load(), store) as session:
                params = calibration_parameters(QUICK_CALIBRATION, session.rig)
                outcome, _ = await run_thrust_calibration(session, params)
                assert outcome.status == "completed"

    SimClock.run(calibrate())
    gc.collect()  # the set-up's garbage goes now, not in a full collection mid-exchange
    return path


class OutputLog:
    """Every change of the simulated controller's outputs, with its monotonic time."""

    def __init__(self, sim: SimulatedRigThread) -> None:
        self.changes: list[tuple[float, list[float]]] = []
        emulator = sim.thrusters
        forward = emulator.on_outputs

        def record(fractions: list[float]) -> None:
            self.changes.append((time.monotonic(), list(fractions)))
            forward(fractions)

        sim.call(lambda: setattr(emulator, "on_outputs", record))

    def thrust_on(self) -> bool:
        return bool(self.changes) and any(self.changes[-1][1])

    def zero_after(self, t: float) -> float | None:
        """When the outputs first went to zero after ``t``; None unless they ended zero."""
        if not self.changes or any(self.changes[-1][1]):
            return None
        return next((when for when, f in self.changes if when >= t and not any(f)), None)


def _start_tow(
    tmp_path: Path, calibrated_db: Path, modbus_port: int, thruster_port: str
) -> tuple[subprocess.Popen, str]:
    """`rig tow --thrusters` on a copy of the calibrated database, the operator's answers
    (carriage at the start, no weight, thrusters free) waiting on its stdin."""
    shutil.copy(calibrated_db, tmp_path / "rig.db")
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    enter = tmp_path / "enter.txt"
    enter.write_text("\n" * 3)
    rig = hardware_rig_file(tmp_path, modbus_port, thruster_port)
    args = ["--force", "15", "--max-time", "30", "--baseline", "0.3", "--rig", str(rig)]
    tow = subprocess.Popen(
        [*RIG, "tow", "--thrusters", *args, "--db", db, "--json"],
        cwd=ROOT,
        stdin=enter.open(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return tow, db


#: Heartbeats asking for thrust (one a clock tick) before the fault: the ramp under way,
#: the vehicle moving, samples from before the fault stored.
THRUST_TICKS = 4


def _wait_for_thrust(
    tow: subprocess.Popen, line: SerialFaultProxy, thrust_on: Callable[[], bool] = lambda: True
) -> None:
    """Until the host has put ``THRUST_TICKS`` frames asking for thrust on the line and
    ``thrust_on()`` (the controller's outputs, where the test can see them)."""

    def thrusting() -> bool:
        assert tow.poll() is None, tow.communicate()
        return sum(_thrust(raw) for _, raw in list(line.from_host)) >= THRUST_TICKS and thrust_on()

    wait_until(thrusting, "the thrust on", timeout_s=30)


def _finish(tow: subprocess.Popen) -> tuple[str, str]:
    try:
        return tow.communicate(timeout=30)
    finally:
        if tow.poll() is None:
            tow.kill()
            tow.wait(5)


def _assert_aborted_and_stored(
    tow: subprocess.Popen, out: str, err: str, db: str, t_fault: float
) -> tuple[dict, list]:
    """The CLI ended with its JSON, no traceback, exit 1; the run is stored aborted with
    every sample the clock produced, from before the fault to the abort. Returns the
    CLI's outcome and the run's events."""
    assert tow.returncode == 1, err
    assert "Traceback" not in err, err
    outcome = printed_json(out)
    assert outcome["status"] == "aborted"
    with Store(db) as store:
        run = store.get_run(outcome["run_id"])
        assert (run.status, run.reason) == ("aborted", outcome["reason"])
        samples = store.samples(run.id)
        assert len(samples) == outcome["samples"] == run.sample_count
        # seq counts clock slots: a gap is only ever a slot the clock skipped (the next
        # sample says OVERRUN), never a sample lost on the way to the store.
        gaps = np.flatnonzero(np.diff(samples.seq) != 1)
        assert all(samples.quality[i + 1] & Quality.OVERRUN for i in gaps)
        assert samples.t_mono[-1] > t_fault
        assert (samples.t_mono < t_fault).sum() >= 5
        events = store.events(run.id)
    (steps,) = [e.data["steps"] for e in events if (e.data or {}).get("action") == "thrust_steps"]
    assert any(any(fractions) for _, _, fractions in steps)  # the ramp the controller confirmed
    return outcome, events


def _thrust(raw: bytes) -> bool:
    """True for a THR frame asking for non-zero thrust."""
    head = raw.split(b"*")[0].split(b",")
    return head[0] == b"$THR" and any(int(c) for c in head[2:])


FAULTS = {
    "replies dropped": {"to_host": "drop"},
    "controller silent": {"to_host": "drop", "to_controller": "drop"},
    "garbage both ways": {"to_host": "garbage", "to_controller": "garbage"},
    "PLC lost": None,
}
#: How each fault's abort reason begins.
REASONS = {
    "replies dropped": f"thruster link lost: {LINK_LOST_AFTER} consecutive replies missing "
    "(no reply within ack_timeout_s)",
    "controller silent": f"thruster link lost: {LINK_LOST_AFTER} consecutive replies missing "
    "(no reply within ack_timeout_s)",
    "garbage both ways": f"thruster link lost: {LINK_LOST_AFTER} consecutive replies missing "
    "(garbage)",
    "PLC lost": "sensor data stale or unread (PLC at tcp 127.0.0.1:",
}


@pytest.mark.parametrize("fault", list(FAULTS))
def test_fault_during_a_thruster_tow_zeroes_the_thrust_and_aborts(
    fault, calibrated_db, tmp_path, record_property
):
    with SimulatedRigThread(RigSource.load().rig) as sim:
        outputs = OutputLog(sim)
        line = SerialFaultProxy(sim.endpoints.thruster_serial_port)
        plc = TcpCutProxy((sim.endpoints.host, sim.endpoints.port))
        try:
            tow, db = _start_tow(tmp_path, calibrated_db, plc.port, line.path)
            _wait_for_thrust(tow, line, outputs.thrust_on)
            thrust_before = list(sim.thrusters.outputs)
            t_fault = plc.cut() if FAULTS[fault] is None else line.set(**FAULTS[fault])
            out, err = _finish(tow)
        finally:
            line.close()
            plc.close()
        watchdog_trips = sim.thrusters.stats.watchdog_trips

    # The controller's outputs went to zero within 0.5 s of the fault and stayed there.
    assert any(thrust_before)
    t_zero = outputs.zero_after(t_fault)
    assert t_zero is not None, outputs.changes[-5:]
    record_property("fault_to_zero_s", t_zero - t_fault)
    print(f"{fault}: controller outputs zero {t_zero - t_fault:.3f} s after the fault")
    assert t_zero - t_fault < ZERO_WITHIN_S
    host_zero = line.first_zero_after(t_fault)
    assert host_zero is not None and host_zero - t_fault < ZERO_WITHIN_S
    print(f"{fault}: host put zero on the wire {host_zero - t_fault:.3f} s after the fault")
    if FAULTS[fault] and FAULTS[fault].get("to_controller") in ("drop", "garbage"):
        assert watchdog_trips == 1  # only the controller's watchdog could zero it

    outcome, events = _assert_aborted_and_stored(tow, out, err, db, t_fault)
    assert outcome["reason"].startswith(REASONS[fault]), outcome["reason"]
    if FAULTS[fault] is not None:
        # When thrust was last confirmed is stored with the run.
        (link,) = [e.data for e in events if (e.data or {}).get("action") == "thruster_fault"]
        assert link["fault"] == "link_lost"
        assert t_fault - 0.3 < link["t_thrust_confirmed"] < t_fault + 0.15
        assert any(link["confirmed_outputs"])


def test_simulator_killed_during_a_thruster_tow(calibrated_db, tmp_path):
    """`rig sim` (PLC and thruster controller in one process) is SIGKILLed mid-tow: the host
    puts zero thrust on the line at once, aborts naming the PLC, keeps every sample and
    the CLI ends with its JSON."""
    sim = subprocess.Popen(
        [*RIG, "sim", "--modbus-port", "0"], cwd=ROOT, stdout=subprocess.PIPE, text=True
    )
    try:
        assert sim.stdout is not None
        ready = json.loads(sim.stdout.readline())
        line = SerialFaultProxy(ready["thrusters"]["serial_port"])
        try:
            tow, db = _start_tow(tmp_path, calibrated_db, ready["modbus"]["port"], line.path)
            _wait_for_thrust(tow, line)
            sim.kill()
            t_fault = time.monotonic()
            out, err = _finish(tow)
        finally:
            line.close()
    finally:
        sim.kill()
        sim.wait(10)

    host_zero = line.first_zero_after(t_fault)
    assert host_zero is not None
    print(f"simulator killed: host put zero on the wire {host_zero - t_fault:.3f} s after")
    assert host_zero - t_fault < ZERO_WITHIN_S
    outcome, _ = _assert_aborted_and_stored(tow, out, err, db, t_fault)
    assert "PLC at tcp 127.0.0.1:" in outcome["reason"], outcome["reason"]
