"""A run says what it lost, and a fit never uses it: the simulated PLC stops answering for a
few ticks mid weight tow (in process, simulated time), the stored run names the gap (event
+ summary), the loader leaves the samples out and says where, `rig estimate` prints it, a
hole beyond a tow's tolerance aborts the run safely, and a campaign repeats such a run. A
stall within the tolerance that meets one of a spin's writes (the operator's act, the
release, the stop) or its readiness check does not fail it either; a PLC that stays silent
still fails the check."""

from __future__ import annotations

import asyncio
import math
import os

import numpy as np
import pytest

from api.cli.estimate import summary_lines
from api.core.campaign_session import damage_of, run_campaign
from api.core.rig_envelope import envelope_of
from daq.procedures.axis_steps import PreconditionFailed
from daq.procedures.motion import run_motion_test
from daq.procedures.requests import spin_parameters, tow_parameters
from daq.run_data import load_run_data
from daq.sample import Quality
from daq.session import RigSession
from daq.store.run_events import RunEvents
from estimation.design.campaign_state import Campaign, Target
from tests.support.cli import run_in_process

pytestmark = pytest.mark.simtime


async def _stall_once(session: RigSession, ticks: int, *, moving: int = 10) -> None:
    """After ``moving`` samples with the tow's brake released, the PLC stops answering until
    ``ticks`` clock ticks have failed, then answers again (once)."""
    assert session.acquisition is not None
    queue = session.acquisition.subscribe(maxsize=100_000, name="test-stall")
    try:
        released = 0
        while released < moving:
            released += (await queue.get()).channels.get("tow_release") == 1
        session.sim.plc.faults.drop = True
        failed = 0
        while failed < ticks:
            failed += bool((await queue.get()).quality & Quality.ERROR)
        session.sim.plc.faults.drop = False
    finally:
        session.acquisition.unsubscribe(queue)


async def _tow_with_stall(session: RigSession, ticks: int):
    params = tow_parameters({"force_n": 44.1, "max_time_s": 4.0, "baseline_s": 0.5}, session.rig)
    stall = asyncio.create_task(_stall_once(session, ticks))
    outcome = await run_motion_test(session, params)
    await asyncio.wait_for(stall, 5)
    return outcome


async def test_a_short_stall_is_named_on_the_run_and_left_out_of_the_fit(session, store, tmp_path):
    outcome = await _tow_with_stall(session, 3)  # a 0.4 s hole: within a tow's 0.5 s
    assert outcome.status == "completed"
    run = store.get_run(outcome.run_id)
    (gap,) = RunEvents.of(store.events(run.id)).losses
    assert (gap.count, gap.reasons) == (3, ("PLC read failed",))
    assert gap.hole_s == pytest.approx(0.4, abs=0.06)
    assert run.samples_lost == f"3 samples lost in 0.4 s at {gap.at_s:.1f} s"
    assert run.summary == f"completed, {run.samples_lost}"
    assert run.to_json()["summary"] == run.summary
    assert "summary" not in store.list_runs()[0].to_json()  # a list does not read events
    shown = run_in_process(["show", run.id, "--db", store.url], cwd=tmp_path, env=dict(os.environ))
    assert f"status     {run.summary}\n" in shown.stdout
    # the loader leaves them out and says where; the fit's times have a hole there
    data = load_run_data(store, run.id)
    (out,) = data.window_report().left_out
    assert (out.count, out.reason, out.in_motion) == (3, "PLC read failed", True)
    at = f"{out.start_s:.1f}–{out.end_s:.1f} s"
    assert out.describe() == f"3 samples left out at {at} (PLC read failed)"
    step = np.diff(data.t)
    assert np.count_nonzero(step > 0.35) == 1 and step.max() == pytest.approx(0.4, abs=0.06)
    # `rig estimate` says so (the window report rides into the result document as is)
    doc = {"runs": [run.id], "coefficients": {}, "result_id": 1}
    doc["windows"] = {run.id: data.window_report().to_json()}
    assert f"  run {run.id[:8]}: {out.describe()}" in summary_lines(doc)
    # within a tow's tolerance: a campaign fits it without the hole (not repeated)
    assert damage_of(store, run.id) is None


async def test_a_stall_beyond_a_tows_tolerance_aborts_it_safely_naming_the_hole(session, store):
    outcome = await _tow_with_stall(session, 10)  # ~1 s without a reply
    assert outcome.status == "aborted"
    assert "samples lost: " in outcome.reason and "a tow tolerates at most 0.5 s" in outcome.reason
    run = store.get_run(outcome.run_id)
    assert run.reason == outcome.reason
    (gap,) = RunEvents.of(store.events(run.id)).losses
    assert gap.count >= 6 and gap.hole_s > 0.5 and gap.reasons == ("PLC read failed",)
    assert run.summary.startswith(f"aborted ({run.reason}), {gap.count} samples lost in")
    (safe,) = [e for e in store.events(run.id) if e.kind == "safe"]
    assert safe.data is not None and "tow_release" in safe.data["brakes_engaged"]
    assert await session.plc.read("tow_release") == 0
    assert damage_of(store, run.id) == run.reason


@pytest.mark.slow  # its fit of the repeated tow: about 40 s
async def test_a_campaign_repeats_a_tow_that_lost_samples_instead_of_fitting_it(session, store):
    campaign = Campaign(Target(0.01, ("surge",), max_runs=1), envelope_of(session.rig))
    entries: list[dict] = []
    stall = asyncio.create_task(_stall_once(session, 10))
    await run_campaign(session, campaign, on_entry=entries.append)
    await asyncio.wait_for(stall, 5)
    repeated, fitted = entries
    assert repeated["repeated"] and "samples lost" in repeated["why"]
    assert fitted["request"] == repeated["request"] and fitted["run_id"] != repeated["run_id"]
    assert campaign.run_ids("surge") == [fitted["run_id"]]  # the damaged run is not fitted
    assert campaign.outcome == "budget: 1 of 1 runs used"


@pytest.mark.parametrize(
    ("channel", "value", "nth"),
    [
        ("sim_spin_weight", 0.5, 1),  # the simulated operator hangs the weight
        ("spin_release", True, 1),  # the release
        ("spin_release", False, 2),  # the stop (the first clears it at the start)
    ],
)
async def test_a_stall_within_a_spins_tolerance_at_one_of_its_writes_does_not_fail_it(
    session, store, monkeypatch, channel, value, nth
):
    """The PLC stops answering for 0.3 s (a busy host; a spin tolerates 0.5 s) from the
    ``nth`` write of ``channel``: the write waits it out and the spin completes. It used to
    fail the job after three tries in about 0.25 s ("PLC write of … (3 attempts)")."""
    faults = session.sim.plc.faults
    write = session.plc.write
    seen: list[float | bool] = []

    async def stall() -> None:
        faults.drop = True
        await session.clock.sleep(0.3)
        faults.drop = False

    async def stalled_write(name: str, written: float | bool, **options: float) -> None:
        if name == channel and bool(written) == bool(value):
            seen.append(written)
            if len(seen) == nth:
                t0 = session.clock.now()
                stalls.append(asyncio.ensure_future(stall()))
                await write(name, written, **options)
                took.append(session.clock.now() - t0)
                return
        await write(name, written, **options)

    stalls: list[asyncio.Future[None]] = []
    took: list[float] = []
    monkeypatch.setattr(session.plc, "write", stalled_write)
    params = spin_parameters({"torque_nm": 0.454, "max_time_s": 1.0}, session.rig)
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome.reason
    assert len(stalls) == 1 and stalls[0].done()
    (waited,) = took  # the write went through once the PLC answered again
    assert waited == pytest.approx(0.3, abs=0.11), took
    assert await session.plc.read("spin_release") == 0  # the brake engaged at the end


def _stall_at_the_readiness_check(session: RigSession, monkeypatch, stall_s: float) -> list[float]:
    """The PLC stops answering for ``stall_s`` (for good: ``math.inf``) as the procedure's
    readiness check subscribes to the clock; returns the instants it began and ended."""
    faults, acq = session.sim.plc.faults, session.acquisition
    assert acq is not None
    subscribe = acq.subscribe
    instants: list[float] = []

    async def stall() -> None:
        instants.append(session.clock.now())
        faults.drop = True
        if stall_s != math.inf:
            await session.clock.sleep(stall_s)
            faults.drop = False
            instants.append(session.clock.now())

    def stalling_subscribe(maxsize: int = 1000, *, name: str | None = None):
        if name == "readiness-check":
            tasks.append(asyncio.ensure_future(stall()))
        return subscribe(maxsize, name=name)

    tasks: list[asyncio.Future[None]] = []
    monkeypatch.setattr(acq, "subscribe", stalling_subscribe)
    return instants


async def test_a_stall_within_a_spins_tolerance_at_its_readiness_check_does_not_fail_it(
    session, store, monkeypatch
):
    """0.45 s without a reply from the start of the check's 0.5 s window (it used to end the
    job "no fresh data from the PLC: check the connection")."""
    instants = _stall_at_the_readiness_check(session, monkeypatch, 0.45)
    params = spin_parameters({"torque_nm": 0.454, "max_time_s": 1.0}, session.rig)
    outcome = await run_motion_test(session, params)
    assert outcome.status == "completed", outcome.reason
    began, ended = instants
    assert ended - began == pytest.approx(0.45)


async def test_a_plc_silent_at_the_readiness_check_still_fails_it_once_lost(session, monkeypatch):
    instants = _stall_at_the_readiness_check(session, monkeypatch, math.inf)
    params = spin_parameters({"torque_nm": 0.454, "max_time_s": 1.0}, session.rig)
    with pytest.raises(PreconditionFailed, match="no fresh data from the PLC"):
        await run_motion_test(session, params)
    assert session.acquisition is not None and session.acquisition.device_lost.is_set()
    waited = session.clock.now() - instants[0]  # the window, then a lost device's time
    assert waited == pytest.approx(0.5 + session.acquisition.device_lost_after_s, abs=0.11)
    session.sim.plc.faults.drop = False
