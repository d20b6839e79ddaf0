"""Live stream of samples and job events to HTTP clients (Server-Sent Events).

The ``Broadcaster`` sits between threads: the rig loop publishes samples and the job
runner publishes job events; each client has its own bounded ``deque`` (drop-oldest)
on the HTTP side. Publishing is an append and a thread-safe wake-up per client, so a
slow or vanished client costs the rig thread nothing more than that and can never
hold up the acquisition clock. Samples are down-sampled per client (``max_hz``).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import math
import threading
import time
from collections import deque
from collections.abc import AsyncIterator
from dataclasses import dataclass, field
from typing import Any

from daq.sample import Sample

#: Events a client may queue before the oldest are dropped.
CLIENT_QUEUE = 256
#: Comment line sent when nothing else was sent for this long (keeps proxies open).
KEEPALIVE_S = 15.0


def sample_json(sample: Sample) -> dict[str, Any]:
    """A sample as JSON (non-finite values become ``null``)."""
    return {
        "seq": sample.seq,
        "t_mono": sample.t_mono,
        "t_wall": sample.t_wall,
        "quality": int(sample.quality),
        "stale": list(sample.stale),
        "channels": {
            k: (v if isinstance(v, float) and math.isfinite(v) else None)
            for k, v in sample.channels.items()
        },
    }


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
    last_sample_t: float = -math.inf
    dropped: int = 0
    sent: int = 0

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

    @property
    def client_count(self) -> int:
        return len(self._clients)

    def add(self, client: Client) -> None:
        with self._lock:
            self._clients.add(client)

    def remove(self, client: Client) -> None:
        with self._lock:
            self._clients.discard(client)

    def publish_sample(self, sample: Sample) -> None:
        """Called on the rig loop for every sample; JSON is built only if someone wants it."""
        self.published_samples += 1
        with self._lock:
            clients = [c for c in self._clients if c.samples]
        data = None
        for c in clients:
            if c.max_hz is not None and sample.t_mono - c.last_sample_t < 1.0 / c.max_hz - 1e-4:
                continue
            c.last_sample_t = sample.t_mono
            data = data or sample_json(sample)
            c.offer("sample", data)

    def publish_job(self, job: dict[str, Any]) -> None:
        """A job changed state or progress."""
        with self._lock:
            clients = [c for c in self._clients if c.jobs]
        for c in clients:
            c.offer("job", job)


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
