"""Live stream of samples and job events to HTTP clients (Server-Sent Events).

The ``Broadcaster`` sits between threads: the rig loop publishes samples and the job
runner publishes job events; each client has its own bounded ``deque`` (drop-oldest)
on the HTTP side. Publishing is an append and a thread-safe wake-up per client, so a
slow or vanished client costs the rig thread nothing more than that and can never
hold up the acquisition clock. Samples are down-sampled per client (``max_hz``) on a
grid of ``1/max_hz`` with half a clock interval of tolerance, so a rate equal to the
clock's keeps every sample despite jitter and the long-run rate never exceeds
``max_hz``. Each ``sample`` event says how many samples were thinned out just before
it (``thinned``); a ``dropped`` event counts events lost because the client read slowly.

Job updates are thinned to what changed: a ``job`` event (the whole job document) when
anything but its progress changed, else a small ``job_progress`` event (``id``, ``kind``,
``state``, ``progress``), at most ``max_hz`` per job — a progress update that comes sooner
is held and sent when it is due, so the last one always arrives.

A ``guard`` event (``{"estop", "hold"}``, as ``GET /api/rig`` → ``guard``) goes to every
client when the service latches or acknowledges an emergency stop, or a hold is taken or
released through it: a page shows a stop pressed elsewhere at once, not at its next poll.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import threading
import time
from collections import deque
from collections.abc import AsyncIterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from daq.sample import Sample
from daq.store.schema import JOB_FINAL

#: Events a client may queue before the oldest are dropped.
CLIENT_QUEUE = 256
#: Comment line sent when nothing else was sent for this long (keeps proxies open).
KEEPALIVE_S = 15.0


def sample_json(sample: Sample, thrusters: Sequence[float] | None = None) -> dict[str, Any]:
    """A sample as JSON (non-finite values become ``null``); ``thrusters`` (the commands
    last sent, fractions of full scale) is added when the rig has thrusters."""
    data: dict[str, Any] = {
        "seq": sample.seq,
        "thinned": 0,
        "t_mono": sample.t_mono,
        "t_wall": sample.t_wall,
        "quality": int(sample.quality),
        "stale": list(sample.stale),
        "channels": {
            k: (v if isinstance(v, float) and math.isfinite(v) else None)
            for k, v in sample.channels.items()
        },
    }
    if thrusters is not None:
        data["thrusters"] = [float(u) for u in thrusters]
    return data


@dataclass(eq=False)
class Client:
    """One connected stream reader; its queue keeps the newest ``CLIENT_QUEUE`` events."""

    loop: asyncio.AbstractEventLoop
    max_hz: float | None
    samples: bool = True
    jobs: bool = True
    queue: deque[tuple[str, dict[str, Any]]] = field(
        default_factory=lambda: deque(maxlen=CLIENT_QUEUE)
    )
    wake: asyncio.Event = field(default_factory=asyncio.Event)
    #: Clock time from which the next sample is due (down-sampling grid).
    next_due: float = -math.inf
    #: Samples thinned out by ``max_hz`` since the last one offered.
    thinned: int = 0
    dropped: int = 0
    sent: int = 0
    #: Per job id: the last document offered, the next time a progress update is due
    #: (loop time), and a progress update held until then.
    job_docs: dict[str, dict[str, Any]] = field(default_factory=dict)
    job_due: dict[str, float] = field(default_factory=dict)
    job_held: dict[str, dict[str, Any]] = field(default_factory=dict)
    _job_lock: threading.Lock = field(default_factory=threading.Lock)

    def wants(self, t: float, slack: float) -> bool:
        """Down-sampling: is the sample at clock time ``t`` due (``slack`` = tolerance)?"""
        if self.max_hz is None:
            return True
        if t < self.next_due - slack:
            self.thinned += 1
            return False
        period = 1.0 / self.max_hz
        # on the grid; after a gap (or at the start) the grid restarts at this sample
        self.next_due = self.next_due + period if t < self.next_due + period else t + period
        return True

    def offer_job(self, job: dict[str, Any]) -> None:
        """A job document: whole when more than its progress changed, else its progress
        (thinned to ``max_hz``). Called from any thread."""
        job_id = job["id"]
        with self._job_lock:
            last = self.job_docs.get(job_id)
            if last == job:  # nothing changed
                return
            changed = last is None or {**last, "progress": None} != {**job, "progress": None}
            if changed:
                self.job_held.pop(job_id, None)
                if job.get("state") in JOB_FINAL:  # nothing follows: forget it
                    self.job_docs.pop(job_id, None)
                    self.job_due.pop(job_id, None)
                else:
                    self.job_docs[job_id] = job
            else:
                self.job_docs[job_id] = job
            update = {k: job.get(k) for k in ("id", "kind", "state", "progress")}
            pending = job_id in self.job_held
            if not changed and self.max_hz is not None:
                self.job_held[job_id] = update
        if changed:
            self.offer("job", job)
        elif self.max_hz is None:
            self.offer("job_progress", update)
        elif not pending:
            with contextlib.suppress(RuntimeError):  # the client's loop has closed
                self.loop.call_soon_threadsafe(self._send_progress_when_due, job_id)

    def _send_progress_when_due(self, job_id: str) -> None:
        """On the client's loop: send the held progress of ``job_id`` now or when due."""
        assert self.max_hz is not None
        now = self.loop.time()
        due = self.job_due.get(job_id, -math.inf)
        if now < due:
            self.loop.call_later(due - now, self._send_progress_when_due, job_id)
            return
        with self._job_lock:
            update = self.job_held.pop(job_id, None)
            if update is not None:
                self.job_due[job_id] = now + 1.0 / self.max_hz
        if update is not None:
            self.offer("job_progress", update)

    def offer(self, kind: str, data: dict[str, Any]) -> None:
        if len(self.queue) == self.queue.maxlen:
            self.dropped += 1
        self.queue.append((kind, data))
        with contextlib.suppress(RuntimeError):  # the client's loop has closed
            self.loop.call_soon_threadsafe(self.wake.set)


class Broadcaster:
    """Fan samples and job events out to stream clients (thread-safe)."""

    def __init__(self) -> None:
        self._clients: set[Client] = set()
        self._lock = threading.Lock()
        self.published_samples = 0
        #: Smoothed interval between published samples (s): the down-sampling tolerance
        #: is half of it.
        self.interval_s = 0.0
        self._last_t: float | None = None

    @property
    def client_count(self) -> int:
        return len(self._clients)

    def add(self, client: Client) -> None:
        with self._lock:
            self._clients.add(client)

    def remove(self, client: Client) -> None:
        with self._lock:
            self._clients.discard(client)

    def publish_sample(self, sample: Sample, thrusters: Sequence[float] | None = None) -> None:
        """Called on the rig loop for every sample (with the thruster commands sent at that
        time, if the rig has thrusters); JSON is built only if someone wants it."""
        self.published_samples += 1
        t = sample.t_mono
        if self._last_t is not None and 0 < t - self._last_t < 1.0:
            step = t - self._last_t
            self.interval_s = step if self.interval_s == 0 else 0.9 * self.interval_s + 0.1 * step
        self._last_t = t
        with self._lock:
            clients = [c for c in self._clients if c.samples]
        data = None
        slack = 0.5 * self.interval_s
        for c in clients:
            if not c.wants(t, slack):
                continue
            data = data or sample_json(sample, thrusters)
            c.offer("sample", data | {"thinned": c.thinned} if c.thinned else data)
            c.thinned = 0

    def publish_job(self, job: dict[str, Any]) -> None:
        """A job changed state or progress."""
        with self._lock:
            clients = [c for c in self._clients if c.jobs]
        for c in clients:
            c.offer_job(job)

    def publish_guard(self, guard: dict[str, Any]) -> None:
        """The rig's guard changed (``RigGuard.state``): to every client."""
        with self._lock:
            clients = list(self._clients)
        for c in clients:
            c.offer("guard", guard)


def _sse(kind: str, data: dict[str, Any]) -> bytes:
    text = json.dumps(data, separators=(",", ":"), allow_nan=False, default=str)
    return f"event: {kind}\ndata: {text}\n\n".encode()


async def sse_events(
    broadcaster: Broadcaster,
    *,
    max_hz: float | None,
    samples: bool = True,
    jobs: bool = True,
    max_events: int | None = None,
    max_s: float | None = None,
) -> AsyncIterator[bytes]:
    """Server-Sent Events for one client until it disconnects (or the optional limits)."""
    client = Client(asyncio.get_running_loop(), max_hz, samples=samples, jobs=jobs)
    broadcaster.add(client)
    end = None if max_s is None else time.monotonic() + max_s
    try:
        yield b": connected\nretry: 2000\n\n"
        while max_events is None or client.sent < max_events:
            timeout = KEEPALIVE_S if end is None else min(KEEPALIVE_S, end - time.monotonic())
            if timeout <= 0:
                return
            if not client.queue:
                client.wake.clear()
                try:
                    await asyncio.wait_for(client.wake.wait(), timeout)
                except TimeoutError:
                    yield b": keep-alive\n\n"
                    continue
            while client.queue and (max_events is None or client.sent < max_events):
                kind, data = client.queue.popleft()
                client.sent += 1
                yield _sse(kind, data)
            if client.dropped:
                yield _sse("dropped", {"count": client.dropped})
                client.dropped = 0
    finally:
        broadcaster.remove(client)
