"""Procedures over the real wire, in real time: a PLC lost mid-run over Modbus TCP (the
server stops and returns on its port: the run aborts with its samples kept and the client
reconnects); thrust steps timed by the thruster link's thread while the event loop is
blocked. The other procedure tests run in process on simulated time (a silent thruster
controller too: test_thrusters_procedures.py)."""

from __future__ import annotations

import asyncio
import time

import numpy as np

from daq.procedures.motion import run_motion_test
from daq.procedures.requests import tow_parameters
from daq.sample import Quality
from tests.support.progress_log import ProgressLog
from tests.support.waiting import until


async def test_plc_lost_mid_run_aborts_keeps_samples_and_reconnects(session, store):
    params = tow_parameters({"force_n": 24.5, "max_time_s": 30, "baseline_s": 0.3}, session.rig)
    progress = ProgressLog()
    task = asyncio.create_task(run_motion_test(session, params, progress=progress))
    await progress.wait(
        lambda p: p.message.startswith("tow:"), "10 samples moving", times=10, task=task
    )
    port = session.sim.endpoints.port
    await asyncio.to_thread(session.sim.call, lambda s: s.plc.stop_server())
    stopped_at = session.latest().seq
    outcome = await asyncio.wait_for(task, 10)
    assert outcome.status == "aborted" and outcome.reason.startswith("device lost: PLC at tcp ")
    table = store.samples(outcome.run_id)
    before = table.seq <= stopped_at
    seqs, quality = table.seq[before], table.quality[before]
    assert len(seqs) >= 10
    # Nothing received was lost: a gap in seq is only ever a slot the clock skipped
    # (flagged OVERRUN on the next sample), never a sample that went missing.
    gaps = np.flatnonzero(np.diff(seqs) > 1)
    assert all(quality[i + 1] & Quality.OVERRUN for i in gaps)
    assert session.thrusters.output == [0.0] * session.rig.thrusters.count
    # The server returns on the same port: the driver reconnects and samples are good again.
    await asyncio.to_thread(session.sim.call, lambda s: s.plc.start_server())
    assert session.sim.endpoints.port == port
    await until(
        lambda: not session.acquisition.device_lost.is_set() and session.latest().quality == 0,
        "good samples again after the reconnect",
        timeout_s=10,
    )
    assert not session.acquisition.device_lost.is_set()
    assert session.latest().quality == 0


async def test_thrust_steps_are_timed_by_the_link_not_by_a_late_event_loop(session):
    """The event loop is blocked (a loaded host) while a command's reply comes back: the
    stored step is bracketed by when the frame went out and its reply was read, not by when
    the loop got round to it, so the drive rebuilt from it is not shifted late."""
    drv = session.live_thrusters
    await session.arm_thrusters()
    try:
        session.set_thrust([0.8, 0.8])  # a ramp, one step per tick
        await until(lambda: any(drv.confirmed), "the ramp under way")
        with drv.recording_outputs() as steps:
            dispatched = time.monotonic()
            sending = asyncio.ensure_future(drv.command([0.8, 0.8]))  # the next ramp step
            await asyncio.sleep(0)  # the frame is handed to the link's thread
            time.sleep(0.3)  # a host too busy to run the loop; the link's thread goes on
            assert await sending
        during = [step for step in steps if step.t_sent >= dispatched]
        assert during and during[0].t_sent < dispatched + 0.1
        assert during[0].t_acked - during[0].t_sent < 0.1  # not the 0.3 s the loop was away
    finally:
        await session.disarm_thrusters()
