"""The steps every test on an axis shares, weight- or thruster-driven: check the
vehicle is at rest, release after a baseline, follow the motion to its end, and the
outcome of the recorded run."""

from __future__ import annotations

import asyncio
import logging
import statistics
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from daq.operator import OperatorAct
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import SpinRequest as SpinParameters
from daq.procedures.requests import TowRequest as TowParameters
from daq.sample import Quality, Sample
from daq.session import RigSession
from daq.store.faults import one_line
from daq.store.run_events import RunAction
from daq.vocabulary import AXES, RunKind

if TYPE_CHECKING:
    from daq.config import RigConfig

log = logging.getLogger(__name__)


#: Largest speed (m/s or rad/s) at which the vehicle counts as at rest.
AT_REST_SPEED = 0.002


class PreconditionFailed(RuntimeError):
    """The rig is not ready for the test (nothing was recorded)."""


@dataclass(frozen=True)
class RunOutcome:
    """How a procedure's run ended."""

    run_id: str
    status: str
    reason: str | None
    kind: str
    samples: int

    def to_json(self) -> dict[str, Any]:
        return {
            "run_id": self.run_id,
            "status": self.status,
            "reason": self.reason,
            "kind": self.kind,
            "samples": self.samples,
        }


@dataclass(frozen=True)
class Axis:
    """The words of one axis a procedure releases and stops (``daq.vocabulary.AXES``):
    position channel, release coil, weight actuator, unit, end switch and the parameter
    that limits its travel."""

    kind: str
    position: str
    release: str
    weight_act: str
    unit: str
    end_switch: str | None = None
    travel_key: str = ""  # the parameter limiting the motion: max_distance_m, max_angle_rad

    @classmethod
    def of(cls, kind: RunKind) -> Axis:
        """The axis words of ``kind`` (``daq.vocabulary.AXES``)."""
        terms = AXES[kind]
        return cls(
            kind,
            terms.position_channel,
            terms.release_coil,
            terms.weight_act,
            terms.unit,
            terms.end_switch,
            terms.travel_key or "",
        )


TOW = Axis.of(RunKind.TOW)
SPIN = Axis.of(RunKind.SPIN)


async def _settled_samples(session: RigSession, seconds: float, abort: AbortSignal) -> list[Sample]:
    """The good samples (neither ERROR nor STALE) of the next ``seconds``. Fewer than two
    (the PLC stalled) and the wait goes on until two came or the acquisition's
    ``device_lost_after_s`` more have passed: a stall the run itself would ride through
    does not fail the check before it."""
    acq = session.acquisition
    assert acq is not None
    queue = acq.subscribe(maxsize=1000, name="readiness-check")
    got: list[Sample] = []
    try:
        loop = asyncio.get_running_loop()
        end = loop.time() + seconds
        late = end + acq.device_lost_after_s
        while True:
            now = loop.time()
            if now >= end and (len(got) >= 2 or now >= late):
                break
            abort.check()
            wait = max(0.05, (end if now < end else late) - now)
            try:
                sample = await asyncio.wait_for(queue.get(), timeout=wait)
            except TimeoutError:
                continue
            if not sample.quality & (Quality.ERROR | Quality.STALE):
                got.append(sample)
    finally:
        acq.unsubscribe(queue)
    return got


async def check_ready(session: RigSession, axis: Axis, abort: AbortSignal) -> float:
    """Vehicle at rest, switch clear, no e-stop; returns the start position."""
    samples = await _settled_samples(session, 0.5, abort)
    if len(samples) < 2:
        raise PreconditionFailed(
            "no fresh data from the PLC: check the connection before starting a test"
        )
    last = samples[-1].channels
    if last.get("estop"):
        raise PreconditionFailed("the emergency stop is pressed: release it before starting a test")
    if axis.end_switch is not None and last.get(axis.end_switch):
        raise PreconditionFailed(
            "the end-of-travel switch is tripped: return the carriage to the start"
        )
    pos = [s.channels[axis.position] for s in samples]
    dt = samples[-1].t_mono - samples[0].t_mono
    speed = abs(pos[-1] - pos[0]) / dt if dt > 0 else 0.0
    if speed > AT_REST_SPEED:
        raise PreconditionFailed(
            f"the vehicle is moving ({speed:.4f} {axis.unit}/s on {axis.position}); "
            "wait until it is at rest"
        )
    return statistics.fmean(pos)


def return_act(params: TowParameters | SpinParameters, rig: RigConfig) -> OperatorAct:
    """The operator act that brings the vehicle to where the test starts: the start of the
    rail (or zero yaw), or the far end for a reverse tow (``Geometry.reverse_start``)."""
    if isinstance(params, SpinParameters):
        return OperatorAct("return_carriage", "Return the vehicle to zero yaw and let it settle")
    if params.reverse:
        far = rig.geometry.reverse_start
        return OperatorAct(
            "return_carriage",
            f"Push the carriage to the far end of the rail ({far:g} m, short of the "
            "end-of-travel switch) and let the vehicle settle",
            far,
            reverse=True,
        )
    return OperatorAct(
        "return_carriage",
        "Return the carriage to the start of the rail and let the vehicle settle",
    )


def check_room(params: TowParameters | SpinParameters, start: float) -> None:
    """A reverse tow travels back toward 0 m: the carriage must start at least its
    distance from there (``PreconditionFailed`` otherwise; nothing recorded)."""
    if not isinstance(params, TowParameters) or not params.reverse:
        return
    assert params.max_distance_m is not None  # checked parameters carry the rig's default
    if start < params.max_distance_m:
        raise PreconditionFailed(
            f"the carriage is at {start:.3f} m: a reverse tow of {params.max_distance_m:g} m "
            "needs it at least that far from the start; push it to the far end of the rail"
        )


async def follow_motion(
    rec: RecordedRun,
    axis: Axis,
    start: float,
    params: TowParameters | SpinParameters,
    report: ProgressCallback,
) -> tuple[str, Sample, float]:
    """Follow a released axis until end of travel, the test's ``max_distance_m`` or
    ``max_angle_rad`` (the limit) or its ``max_time_s``.

    Returns why it stopped, the sample that decided it, and the time of the last sample
    of free motion (the end-of-travel switch stops the carriage before the sample that
    sees it tripped). Unread ticks are skipped; ``rec.samples()`` aborts on device loss.
    """
    limit = getattr(params, axis.travel_key)  # max_distance_m, max_angle_rad
    max_time_s = params.max_time_s
    assert limit is not None and max_time_s is not None  # checked: the rig's defaults are set
    t0 = previous_t = None
    async for sample in rec.samples():
        if sample.quality & Quality.ERROR:
            continue
        t0 = t0 if t0 is not None else sample.t_mono
        elapsed = sample.t_mono - t0
        travelled = abs(sample.channels[axis.position] - start)
        done = max(elapsed / max_time_s, travelled / limit)
        report(
            Progress(
                0.05 + 0.9 * min(done, 1.0),
                f"{axis.kind}: {travelled:.3f} {axis.unit} in {elapsed:.1f} s",
            )
        )
        if axis.end_switch is not None and sample.channels.get(axis.end_switch):
            return "end of travel", sample, previous_t if previous_t is not None else t0
        if travelled >= limit:
            what = axis.travel_key.rsplit("_", 1)[0].replace("_", " ")  # "max distance"
            return f"{what} {limit:g} {axis.unit}", sample, sample.t_mono
        if elapsed >= max_time_s:
            return f"max time {max_time_s:g} s", sample, sample.t_mono
        previous_t = sample.t_mono
    raise AssertionError("rec.samples() ends only by raising")


async def run_outcome(
    session: RigSession, rec: RecordedRun, kind: str, report: ProgressCallback
) -> RunOutcome:
    """How the recorded run ended (status, reason, samples stored), reported as done."""
    assert rec.run_id is not None and rec.status is not None
    try:
        count = await asyncio.to_thread(session.store.sample_count, rec.run_id)
    except Exception as err:  # storage failed: what this recorder stored is the count
        log.warning("run %s: cannot count its samples: %s", rec.run_id, one_line(err))
        count = rec.samples_stored
    report(
        Progress(
            1.0,
            f"run {rec.status}" + (f": {rec.reason}" if rec.reason else ""),
            state=rec.status,
        )
    )
    return RunOutcome(rec.run_id, rec.status, rec.reason, kind, count)


async def baseline_then_release(
    session: RigSession,
    rec: RecordedRun,
    baseline_s: float,
    channel: str,
    report: ProgressCallback,
    what: str = "brake released",
) -> None:
    """Record the at-rest baseline, then set the release coil and log a ``release`` event.

    The instant is bracketed by the write and its acknowledgement (``t_mono`` ± ``t_half_width``):
    estimation carries that timing uncertainty.
    """
    report(Progress(0.05, f"recording a {baseline_s:g} s baseline", extra={"run_id": rec.run_id}))
    await rec.record_for(baseline_s)
    before = session.clock.now()
    await session.live_plc.write(channel, True)
    after = session.clock.now()  # the PLC acknowledged: the release happened in between
    latest = session.latest()
    await rec.event(
        "operator",
        f"{channel} set: {what}",
        action=RunAction.RELEASE,
        seq=latest.seq if latest else None,
        t_mono=(before + after) / 2,
        t_half_width=(after - before) / 2,
    )


async def engage_and_log_stop(
    rec: RecordedRun,
    release: str,
    message: str,
    action: RunAction,
    sample: Sample,
    t_last_free: float | None = None,
) -> None:
    """End a test's free motion: clear the ``release`` coil (brake or latch engaged), then
    log the ``limit`` event saying why (``message``), with the sample that decided it, the
    time now and the time of the last sample of free motion (default: ``sample``'s)."""
    await rec.session.live_plc.write(release, False)
    await rec.event(
        "limit",
        message,
        action=action,
        seq=sample.seq,
        t_mono=rec.session.clock.now(),
        t_last_free=sample.t_mono if t_last_free is None else t_last_free,
    )
