"""Pendulum free-decay test: the vehicle on the pendulum, pulled out, released, recorded.

Lifecycle (like the tow): rig lock, safe state with the pendulum's latch engaged, the
operator mounts the vehicle and pulls the pendulum out to the start angle (the latch
holds it), the rig checks it is held at rest near that angle, a pre-trigger baseline,
the latch lets go (a bracketed ``release`` event, as for the tow), the swing is recorded
until its amplitude over the last full cycle falls below ``stop_amplitude_rad`` or
``max_time_s`` passes, then the pendulum is caught (``catch`` event). Thrusters stay at
zero throughout. On the simulated rig the procedure plays the operator.
"""

from __future__ import annotations

import contextlib
import math
from collections import deque

from daq.operator import OperatorAct
from daq.procedures.axis_steps import (
    Axis,
    PreconditionFailed,
    RunOutcome,
    baseline_then_release,
    check_ready,
    engage_and_log_stop,
    run_outcome,
)
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal, ProgressCallback, RecordedRun
from daq.procedures.requests import PendulumRequest as PendulumParameters
from daq.sample import Quality, Sample
from daq.session import RigSession
from daq.store.run_events import RunAction
from daq.vocabulary import RunKind

PENDULUM = Axis.of(RunKind.PENDULUM)


class CycleAmplitude:
    """Amplitude of a swing over its last full cycle, fed one sample at a time.

    A cycle runs between two upward crossings of ``centre`` (interpolated); the amplitude
    is half the peak-to-peak of the samples within the last cycle's length, so a
    pendulum stuck by dry friction (no more crossings) also reads as stopped.
    """

    def __init__(self, centre: float = 0.0) -> None:
        self.centre = centre
        self.crossings: list[float] = []
        self._window: deque[tuple[float, float]] = deque()

    @property
    def period_s(self) -> float | None:
        """Length of the last full cycle, s (None before the first one)."""
        if len(self.crossings) < 2:
            return None
        return self.crossings[-1] - self.crossings[-2]

    def add(self, t: float, angle: float) -> float | None:
        """Add a sample; returns the amplitude over the last full cycle (None: none yet)."""
        if self._window:
            t0, a0 = self._window[-1]
            x0, x1 = a0 - self.centre, angle - self.centre
            if x0 < 0 <= x1 and t > t0:
                self.crossings.append(t0 - x0 * (t - t0) / (x1 - x0))
        self._window.append((t, angle))
        period = self.period_s
        if period is None:
            return None
        while self._window[0][0] < t - period:
            self._window.popleft()
        values = [a for _, a in self._window]
        return (max(values) - min(values)) / 2


async def run_pendulum_decay(
    session: RigSession,
    params: PendulumParameters,
    *,
    abort: AbortSignal | None = None,
    progress: ProgressCallback | None = None,
) -> RunOutcome:
    """Run one free-decay test under the rig lock; see the module docstring."""
    abort = abort or AbortSignal()
    report = progress or (lambda p: None)
    pendulum = session.rig.pendulum
    if pendulum is None:  # pendulum_parameters refuses this before; keep the promise here
        raise PreconditionFailed("the rig file has no [pendulum] section")
    start = params.start_angle_rad
    assert start is not None  # checked: required
    async with session.locked(f"pendulum {start:.3g} rad"):
        op = session.operator
        report(Progress(0.0, "mounting the vehicle on the pendulum"))
        await session.safe_state()
        await session.live_plc.write(PENDULUM.release, False)  # the latch engaged
        await op.perform(
            OperatorAct(
                "mount_pendulum",
                f"Mount the vehicle on the pendulum ({pendulum.axis} through the water) "
                "and let it hang at rest",
            )
        )
        report(Progress(0.02, f"pulling the pendulum out to {start:.3f} rad"))
        await op.perform(
            OperatorAct(
                PENDULUM.weight_act,
                f"Pull the pendulum out to {start:.3f} rad ({math.degrees(start):.1f}°) "
                "and hook it on the release latch",
                start,
            )
        )
        held = await check_ready(session, PENDULUM, abort)
        tolerance = max(0.02, 0.1 * start)
        if abs(held - start) > tolerance:
            raise PreconditionFailed(
                f"the pendulum is held at {held:.3f} rad, asked for {start:.3f} rad "
                f"(± {tolerance:.3f}): pull it out to the start angle"
            )
        rec = RecordedRun(
            session, kind=PENDULUM.kind, parameters=params.to_json(), abort=abort, progress=report
        )
        async with rec:
            caught = False
            try:
                await rec.event(
                    "operator",
                    f"pendulum pulled out to {held:.4f} rad and held",
                    held_angle_rad=held,
                )
                await baseline_then_release(
                    session, rec, params.baseline_s, PENDULUM.release, report, "latch released"
                )
                stop, last = await _follow_decay(rec, params, held, report)
                await engage_and_log_stop(
                    rec, PENDULUM.release, f"{stop}: pendulum caught", RunAction.CATCH, last
                )
                caught = True
            finally:
                if not caught:  # abort, device loss: never leave it swinging
                    with contextlib.suppress(Exception):
                        await session.live_plc.write(PENDULUM.release, False)
            await rec.record_for(0.3)  # a short tail shows the catch in the data
        return await run_outcome(session, rec, PENDULUM.kind, report)


async def _follow_decay(
    rec: RecordedRun, params: PendulumParameters, held: float, report: ProgressCallback
) -> tuple[str, Sample]:
    """Follow the swing until it has decayed or time is up; returns why and the last sample."""
    cycle = CycleAmplitude()
    t0: float | None = None
    decades = math.log(abs(held) / params.stop_amplitude_rad)
    max_time_s = params.max_time_s
    assert max_time_s is not None  # checked: the rig's default is set
    async for sample in rec.samples():
        if sample.quality & Quality.ERROR:
            continue
        angle = sample.channels.get(PENDULUM.position)
        if angle is None or not math.isfinite(angle):
            continue
        t0 = t0 if t0 is not None else sample.t_mono
        elapsed = sample.t_mono - t0
        amplitude = cycle.add(sample.t_mono, angle)
        decayed = (
            0.0 if amplitude is None else math.log(abs(held) / max(amplitude, 1e-12)) / decades
        )
        shown = "…" if amplitude is None else f"{amplitude:.4f} rad"
        report(
            Progress(
                0.05 + 0.9 * min(max(elapsed / max_time_s, decayed), 1.0),
                f"pendulum: amplitude {shown} after {elapsed:.1f} s",
            )
        )
        if amplitude is not None and amplitude < params.stop_amplitude_rad:
            return f"amplitude {amplitude:.4f} rad < {params.stop_amplitude_rad:g} rad", sample
        if elapsed >= max_time_s:
            return f"max time {max_time_s:g} s", sample
    raise AssertionError("rec.samples() ends only by raising")
