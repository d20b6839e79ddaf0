"""Thruster driver: host-side limits, heartbeat and zero-on-exit over the line protocol.

Serial I/O runs on one dedicated worker thread (``SerialLink``), so no call blocks the
event loop. Every way out — ``close()``, ``async with`` (normal exit or exception),
SIGINT/SIGTERM via ``install_signal_handlers`` and an ``atexit`` fallback
(``thrusters.exit_safety``) — leaves the thrusters commanded to zero. See
``docs/thruster-protocol.md``.

The driver is one state machine (link, confirmed outputs, slew limiter, fault, watchdog)
driven from one event loop; what it reports (errors, faults, status, output steps) is in
``thrusters.status``, whose names are re-exported here.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import serial

from thrusters import protocol as p
from thrusters.exit_safety import ExitSafety
from thrusters.link import LinkStats, SerialLink
from thrusters.link_supervision import LinkSupervisor
from thrusters.settings import MAX_SLEW_INTERVAL_S, CommandLimits, ThrusterPort
from thrusters.status import (
    LINK_LOST_AFTER,
    NoReply,
    OutputStep,
    ThrusterError,
    ThrusterFault,
    ThrusterStatus,
    describe_reply,
)

__all__ = [
    "LINK_LOST_AFTER",
    "MAX_SLEW_INTERVAL_S",
    "OutputStep",
    "ThrusterDriver",
    "ThrusterError",
    "ThrusterFault",
    "ThrusterStatus",
]

log = logging.getLogger(__name__)


#: Queries that open the link before a silent controller is reported (each waits
#: ``ack_timeout_s``: 0.5 s at the default 0.1 s; the port is open, nothing moves).
OPEN_QUERY_ATTEMPTS = 5


class ThrusterDriver:
    """Driver for the thruster controller named in the rig file's ``[thrusters]`` section.

    ``port`` overrides ``cfg.port`` (needed when the rig file says ``"sim"``: the simulated
    rig hands over its pty path or ``socket://`` URL). ``clock`` is the monotonic time
    source of the slew limiter and of every time the driver stamps (tests pass their own
    to make ramps byte-exact; a simulated rig its ``daq.clock.Clock.now``). ``link``
    replaces the serial link built from the port (tests pass one over an in-memory port).
    """

    def __init__(
        self,
        cfg: ThrusterPort,
        limits: CommandLimits,
        *,
        port: str | None = None,
        clock: Callable[[], float] = time.monotonic,
        link: SerialLink | None = None,
    ) -> None:
        url = link.url if link is not None else port or cfg.port
        if url == "sim":
            raise ValueError(
                "thrusters.port: 'sim' must be resolved to the simulator's pty path or "
                "socket:// URL (pass port=...), got 'sim'"
            )
        self.cfg = cfg
        self.clock = clock
        self.limits = limits
        self.count = cfg.count
        self._link = link or SerialLink(url, cfg.baudrate, cfg.ack_timeout_s)
        self._executor: ThreadPoolExecutor | None = None
        self._inline = asyncio.Lock()  # a non-blocking link's frames, in turn
        self._seq = 0
        self.state = "UNKNOWN"
        #: An ARM was sent and no reply since has shown the controller DISARMED.
        self._maybe_armed = False
        #: Commands last sent, as fractions of full scale (after clamp and slew limit).
        self.output: list[float] = [0.0] * self.count
        #: Commands asked for by the caller, after clamping.
        self.target: list[float] = [0.0] * self.count
        self._last_step_t: float | None = None
        #: Why commands are held at zero (stale sensors, shutting down), or None.
        self.inhibited: str | None = None
        self.clamped_commands = 0
        #: Outputs the controller last confirmed (ACK, or zero when it is not armed).
        self._confirmed: tuple[float, ...] = (0.0,) * self.count
        self._t_confirmed = self.clock()
        #: Host times just before the last frame went out and when its reply was read (as the
        #: link's thread saw them; when no reply came, when this driver saw the timeout).
        self.last_bracket: tuple[float, float] = (self._t_confirmed, self._t_confirmed)
        self._output_logs: list[list[OutputStep]] = []
        #: Lost-link and watchdog detection (the fault a run waits for).
        self.supervisor = LinkSupervisor(clock)
        #: Zero on SIGINT/SIGTERM and at interpreter exit.
        self.exit_safety = ExitSafety(self)

    @property
    def is_open(self) -> bool:
        return self._link.is_open

    @property
    def fault(self) -> ThrusterFault | None:
        """The first fault since the last ``arm()`` (link lost, watchdog trip), or None."""
        return self.supervisor.fault

    @property
    def missed_replies(self) -> int:
        """Frames in a row without a valid reply."""
        return self.supervisor.missed_replies

    @property
    def link_lost(self) -> bool:
        return self.supervisor.link_lost

    async def wait_fault(self) -> ThrusterFault:
        """Wait until the link is lost or the controller's watchdog trips (since the last
        ``arm()``) and return that fault."""
        return await self.supervisor.wait_fault()

    def install_signal_handlers(
        self,
        loop: asyncio.AbstractEventLoop | None = None,
        *,
        then: Callable[[int], None] | None = None,
    ) -> None:
        """On SIGINT/SIGTERM: zero, disarm and close, then ``then(signum)`` (default:
        re-raise the signal); see :class:`thrusters.exit_safety.ExitSafety`."""
        self.exit_safety.install_signal_handlers(loop, then=then)

    def write_zero_frames(self) -> None:
        """Write zero and DISARM frames synchronously on the link, awaiting no reply: the
        last resort at interpreter exit (``thrusters.exit_safety``)."""
        self._seq = p.next_seq(self._seq)
        self._link.write_raw(p.thr_frame(self._seq, [0] * self.count))
        self._seq = p.next_seq(self._seq)
        self._link.write_raw(p.disarm_frame(self._seq))

    @property
    def stats(self) -> LinkStats:
        """Counters: sent, acked, naks by reason, timeouts, garbage/corrupt lines, I/O errors."""
        return self._link.stats

    # ---- life cycle -------------------------------------------------------------------

    async def open(self, *, io_thread_setup: Callable[[], object] | None = None) -> None:
        """Open the port and query the controller; ThrusterError if it does not answer.
        ``io_thread_setup`` runs first in the thread that does the line's blocking I/O (a
        real-time session raises that thread's scheduling there: ``daq.priority``)."""
        self._executor = ThreadPoolExecutor(
            max_workers=1, thread_name_prefix="thrusters", initializer=io_thread_setup
        )
        try:
            await self._run(self._link.open)
        except (OSError, serial.SerialException, ValueError) as err:  # ValueError: bad URL
            self._executor.shutdown(wait=False)
            self._executor = None
            raise ThrusterError(
                f"thruster controller: thrusters.port: cannot open {self._link.url!r}: {err}"
            ) from err
        self.exit_safety.register_at_exit()
        self.inhibited = None
        self._clear_fault()
        try:
            await self._first_query()
        except ThrusterError as err:
            await self._close_port()
            raise ThrusterError(
                f"thruster controller at thrusters.port {self._link.url!r}: {err}"
            ) from err

    async def close(self) -> None:
        """Command zero (waiting for the ACK, ≤ 3 retries), disarm, close. Never raises.

        A controller that said DISARMED after the last ARM this driver sent (or that was
        never sent an ARM) holds its outputs at zero: nothing is sent, so a weight-driven
        run leaves the thruster line quiet."""
        if not self.is_open:
            return
        self.inhibited = "shutting down"
        if self.state == "DISARMED" and not self._maybe_armed:
            await self._close_port()
            return
        try:
            if not await self.zero():
                log.error("thrusters: zero command was not acknowledged before close")
            await self.disarm()
        except Exception as err:
            log.error("thrusters: disarm on close failed: %s", err)
        await self._close_port()

    async def _close_port(self) -> None:
        self.exit_safety.unregister_at_exit()
        if self._executor is not None:
            await self._run(self._link.close)
            self._executor.shutdown(wait=False)
            self._executor = None

    async def __aenter__(self) -> ThrusterDriver:
        await self.open()
        return self

    async def __aexit__(self, *exc: object) -> None:
        await self.close()

    # ---- operator requests ------------------------------------------------------------

    async def arm(self) -> None:
        """Arm the controller (from DISARMED or WDT); outputs start from zero."""
        self._maybe_armed = True
        reply = await self._transact(p.arm_frame, self._zeros)
        self._expect_ack(reply, "arm")
        self._clear_fault()
        self.output = [0.0] * self.count
        self.target = [0.0] * self.count
        self._last_step_t = self.clock()

    async def disarm(self) -> None:
        """Disarm: the controller zeroes its outputs."""
        self.target = self.output = [0.0] * self.count
        self._expect_ack(await self._transact(p.disarm_frame, self._zeros), "disarm")

    async def _first_query(self) -> ThrusterStatus:
        """``query`` asked up to ``OPEN_QUERY_ATTEMPTS`` times while nothing answers (a board
        that resets when its port opens, a loaded host); a wrong answer is not asked again."""
        for attempt in range(1, OPEN_QUERY_ATTEMPTS):
            try:
                return await self.query()
            except NoReply:
                log.warning("thrusters: no reply to the opening query (attempt %d)", attempt)
        return await self.query()

    async def query(self) -> ThrusterStatus:
        """Controller state and measured RPM/current per thruster."""
        reply = await self._transact(p.qry_frame)
        if reply is None:
            raise NoReply(f"query: controller at {self._link.url} gave {describe_reply(reply)}")
        if reply.kind != "STA":
            raise ThrusterError(
                f"query: controller at {self._link.url} gave {describe_reply(reply)}"
            )
        if len(reply.rpm) != self.count:
            raise ThrusterError(
                f"query: controller reports {len(reply.rpm)} thrusters, "
                f"rig file thrusters.count is {self.count}"
            )
        self.state = reply.state or "UNKNOWN"
        return ThrusterStatus(reply.state or "", reply.rpm, reply.current_a, self.clock())

    # ---- commanding -------------------------------------------------------------------

    async def command(self, fractions: Sequence[float]) -> bool:
        """Ask for thrust per thruster as a fraction of full scale (+ = forward).

        Values are clamped to ±``limits.max_thruster_command`` and the sent command moves
        toward them at most ``limits.max_command_slew_per_s`` per second (the rest of the
        ramp is sent by ``heartbeat``). Returns True when the controller ACKed.
        """
        if len(fractions) != self.count:
            raise ValueError(
                f"fractions: one value per thruster ({self.count}) needed, got {len(fractions)}"
            )
        limit = self.limits.max_thruster_command
        target = []
        for i, f in enumerate(fractions):
            if not isinstance(f, int | float) or not math.isfinite(f):
                raise ValueError(f"thruster {i}: command must be a finite fraction, got {f!r}")
            clamped = min(max(float(f), -limit), limit)
            if clamped != f:
                self.clamped_commands += 1
            target.append(clamped)
        self.target = target
        return await self._step()

    async def heartbeat(self) -> bool:
        """Re-send the (slew-limited) command; call every clock tick while armed."""
        return await self._step()

    async def zero(self, retries: int = 3) -> bool:
        """Command zero at once (no ramp) and wait for the ACK, retrying up to ``retries``
        times. A ``NAK disarmed`` counts as success (outputs are zero in DISARMED/WDT); if
        the controller answers but keeps refusing, DISARM is the last resort. On a link
        already lost when called, a frame without a reply is not retried: the zero is on
        the line once per call, and the controller's watchdog holds it at zero."""
        self.target = self.output = [0.0] * self.count
        self._last_step_t = self.clock()
        zeros = [0] * self.count
        answered, lost = False, self.link_lost
        for attempt in range(retries + 1):
            reply = await self._transact(lambda seq: p.thr_frame(seq, zeros), self._zeros)
            if reply is not None and (reply.kind == "ACK" or reply.reason == "disarmed"):
                return True
            answered = answered or reply is not None
            log.warning("thrusters: zero attempt %d got %s", attempt + 1, describe_reply(reply))
            if lost and reply is None:
                break  # nobody answers: more tries would only wait out more timeouts
        if answered:
            reply = await self._transact(p.disarm_frame, self._zeros)
            return reply is not None and reply.kind == "ACK"
        return False

    async def zero_on_stale(self, stale: bool, *, reason: str = "sensor data stale") -> None:
        """Policy hook for the acquisition/procedure layer: while ``stale`` is True the
        thrusters are held at zero (commands are replaced by zeros); False releases them
        (they ramp up again under the slew limit)."""
        if stale and self.inhibited is None:
            log.warning("thrusters: %s: commanding zero", reason)
            self.inhibited = reason
            await self.zero()
        elif not stale and self.inhibited == reason:
            self.inhibited = None

    async def _step(self) -> bool:
        now = self.clock()
        if self.inhibited is not None:
            new = [0.0] * self.count
        else:
            dt = MAX_SLEW_INTERVAL_S if self._last_step_t is None else now - self._last_step_t
            max_step = self.limits.max_command_slew_per_s * min(dt, MAX_SLEW_INTERVAL_S)
            new = [
                out + min(max(tgt - out, -max_step), max_step)
                for out, tgt in zip(self.output, self.target, strict=True)
            ]
        self.output, self._last_step_t = new, now
        commands = [p.fraction_to_command(x, i) for i, x in enumerate(new)]
        sent = tuple(c / 1000 for c in commands)
        lost_before = self.link_lost
        reply = await self._transact(lambda seq: p.thr_frame(seq, commands), sent)
        if self.link_lost and not lost_before:
            # Put one zero frame on the wire now rather than at the next heartbeat: the
            # controller may still hear us even if we cannot hear it.
            await self._transact(lambda seq: p.thr_frame(seq, [0] * self.count), self._zeros)
        return reply is not None and reply.kind == "ACK"

    # ---- supervision ------------------------------------------------------------------

    @property
    def confirmed(self) -> tuple[float, ...]:
        """The outputs the controller last confirmed (fractions of full scale)."""
        return self._confirmed

    @contextlib.contextmanager
    def recording_outputs(self) -> Iterator[list[OutputStep]]:
        """Collect every change of the controller's outputs while the block runs: the
        thrust a run actually got, whatever the heartbeat's timing (a test's drive is
        rebuilt from it, not from a model of the ramp)."""
        steps: list[OutputStep] = []
        self._output_logs.append(steps)
        try:
            yield steps
        finally:
            self._output_logs.remove(steps)

    @property
    def _zeros(self) -> tuple[float, ...]:
        return (0.0,) * self.count

    def _confirm(self, outputs: tuple[float, ...], t_sent: float, t_acked: float) -> None:
        if outputs != self._confirmed:
            step = OutputStep(t_sent, t_acked, outputs)
            for steps in self._output_logs:
                steps.append(step)
        self._confirmed, self._t_confirmed = outputs, t_acked

    # ---- plumbing ---------------------------------------------------------------------

    async def _run(self, fn: Callable[..., object], *args: object) -> object:
        if self._executor is None:
            raise ThrusterError(f"thruster driver for {self._link.url} is not open")
        if not self._link.blocking:  # an in-process link (simulated time): no thread
            async with self._inline:  # one frame at a time, as on the link's one thread
                result = fn(*args)
                await self._link.wait_on_loop()  # a reply timeout: the loop runs on meanwhile
            return result
        return await asyncio.get_running_loop().run_in_executor(self._executor, fn, *args)

    async def _transact(
        self, make: Callable[[int], bytes], outputs: tuple[float, ...] | None = None
    ) -> p.Reply | None:
        """Send one frame; ``outputs`` are the controller's outputs once it ACKs it."""
        self._seq = p.next_seq(self._seq)
        seq = self._seq
        t_sent = self.clock()
        before = dataclasses.replace(self._link.stats)
        exchanged = await self._run(self._exchange, make(seq), seq)
        assert isinstance(exchanged, tuple)
        reply, bracket = exchanged
        assert reply is None or isinstance(reply, p.Reply)
        # The link's own send/reply times: this coroutine may resume late on a loaded host.
        t_sent, t_reply = self.last_bracket = bracket or (t_sent, self.clock())
        was_armed = self.state == "ARMED"
        if reply is not None and reply.state:
            self.state = reply.state
            if reply.state == "DISARMED":
                self._maybe_armed = False
        elif reply is not None and reply.reason == "disarmed" and self.state == "ARMED":
            # Only the watchdog takes the controller out of ARMED without our DISARM.
            self.state = "WDT"
        if was_armed and self.state == "WDT":
            self.supervisor.report(
                "watchdog",
                "thruster controller watchdog tripped (heartbeats lost): "
                "thrust went to zero mid-run",
                self._t_confirmed,
                self._confirmed,
            )
        armed = self.state == "ARMED"
        t_confirmed, confirmed = self._t_confirmed, self._confirmed
        after = self._link.stats
        if self.supervisor.observe(
            reply, before, after, armed=armed, t_confirmed=t_confirmed, confirmed=confirmed
        ):
            self.inhibited = "thruster link lost"
        if reply is not None and reply.kind == "ACK" and outputs is not None:
            self._confirm(outputs, t_sent, t_reply)
        elif reply is not None and reply.reason == "disarmed":
            # Not armed: outputs are zero, since some time after the last confirmation.
            self._confirm(self._zeros, self._t_confirmed, t_reply)
        return reply

    def _exchange(self, raw: bytes, seq: int) -> tuple[p.Reply | None, tuple[float, float] | None]:
        """In the link's thread: the reply and its send/reply times, read together (the next
        frame, queued behind this one, must not overwrite the times first)."""
        return self._link.transact(raw, seq), self._link.last_bracket

    def _clear_fault(self) -> None:
        self.supervisor.clear()
        if self.inhibited == "thruster link lost":
            self.inhibited = None

    def _expect_ack(self, reply: p.Reply | None, what: str) -> None:
        if reply is None or reply.kind != "ACK":
            raise ThrusterError(
                f"{what}: controller at {self._link.url} gave {describe_reply(reply)}"
            )
