"""The hand-off between the acquisition clock and the database.

The clock's consumer calls :meth:`RunRecorder.put` (never waits); :meth:`RunRecorder.run`
writes whatever is queued at least every ``flush_interval_s`` (≤ 1 s) in a worker thread,
so the event loop never blocks on SQLite or PostgreSQL. A failed write keeps its samples
queued and is retried at the next flush; samples whose (run, seq) is already stored are
dropped and counted, the rest of their batch is kept.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any

from daq.sample import Sample
from daq.store.records import DuplicateSample
from daq.store.store import Store

log = logging.getLogger(__name__)


@dataclass
class RecorderStats:
    """Counters of one recorder: what was stored, how long flushes took, what was lost."""

    samples_stored: int = 0
    batches: int = 0
    max_flush_s: float = 0.0
    last_flush_s: float = 0.0
    dropped_queue_full: int = 0
    discarded_duplicates: int = 0
    failed_flushes: int = 0
    last_error: str | None = None

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)


class RunRecorder:
    """Batches samples of one run into the store, flushing at least every
    ``flush_interval_s`` seconds; at most ``max_queue`` samples wait in memory (more are
    dropped and counted, so a stuck database can never exhaust memory or stall the clock)."""

    def __init__(
        self,
        store: Store,
        run_id: str,
        *,
        flush_interval_s: float = 0.5,
        max_queue: int = 100_000,
        max_batch: int = 50_000,
    ) -> None:
        if not (isinstance(flush_interval_s, int | float) and 0 < flush_interval_s <= 1.0):
            raise ValueError(
                f"flush_interval_s: {flush_interval_s!r} is not allowed; use 0 < s ≤ 1 "
                "(samples must reach the database within a second)"
            )
        if isinstance(max_queue, bool) or not isinstance(max_queue, int) or max_queue < 1:
            raise ValueError(f"max_queue: {max_queue!r} is not allowed; use an integer ≥ 1")
        if isinstance(max_batch, bool) or not isinstance(max_batch, int) or max_batch < 1:
            raise ValueError(f"max_batch: {max_batch!r} is not allowed; use an integer ≥ 1")
        self.store = store
        self.run_id = store.get_run(run_id).id
        self.flush_interval_s = float(flush_interval_s)
        self.max_queue = max_queue
        self.max_batch = max_batch
        self.stats = RecorderStats()
        self._queue: deque[Sample] = deque()
        self._close_requested = asyncio.Event()
        self._running = False
        self._stopped = asyncio.Event()
        self._flush_lock = asyncio.Lock()

    @property
    def queued(self) -> int:
        """Samples waiting for the next flush."""
        return len(self._queue)

    def put(self, sample: Sample) -> None:
        """Queue one sample; never blocks (drops and counts it when the queue is full)."""
        if len(self._queue) >= self.max_queue:
            self.stats.dropped_queue_full += 1
            if self.stats.dropped_queue_full == 1:
                log.error("run %s: recorder queue full (%d); dropping", self.run_id, self.max_queue)
            return
        self._queue.append(sample)

    async def run(self) -> None:
        """Flush on a fixed schedule until :meth:`close` is called (then flush the rest)."""
        loop = asyncio.get_running_loop()
        self._running = True
        try:
            next_flush = loop.time() + self.flush_interval_s
            while not self._close_requested.is_set():
                timeout = max(0.0, next_flush - loop.time())
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._close_requested.wait(), timeout)
                now = loop.time()
                next_flush += self.flush_interval_s
                if next_flush < now:  # a slow flush: keep the interval from now, no burst
                    next_flush = now + self.flush_interval_s
                await self.flush()
        finally:
            self._running = False
            self._stopped.set()

    async def flush(self) -> int:
        """Write everything queued now; returns how many samples were stored."""
        stored = 0
        async with self._flush_lock:
            while self._queue:
                count = min(len(self._queue), self.max_batch)
                batch = [self._queue.popleft() for _ in range(count)]
                started = time.perf_counter()
                try:
                    try:
                        written = await asyncio.to_thread(
                            self.store.add_samples, self.run_id, batch
                        )
                    except DuplicateSample as exc:  # keep the new samples, drop the repeats
                        self.stats.last_error = str(exc)
                        log.error("%s", exc)
                        written = await asyncio.to_thread(
                            self.store.add_samples, self.run_id, batch, skip_existing=True
                        )
                        self.stats.discarded_duplicates += len(batch) - written
                except Exception as exc:
                    self._queue.extendleft(reversed(batch))
                    self.stats.failed_flushes += 1
                    self.stats.last_error = f"{type(exc).__name__}: {exc}"
                    log.warning("run %s: flush failed, will retry: %s", self.run_id, exc)
                    break
                elapsed = time.perf_counter() - started
                self.stats.samples_stored += written
                self.stats.batches += 1
                self.stats.last_flush_s = elapsed
                self.stats.max_flush_s = max(self.stats.max_flush_s, elapsed)
                stored += written
        return stored

    async def close(self, *, retries: int = 3, retry_delay_s: float = 0.2) -> None:
        """Stop :meth:`run` and store everything still queued; raises RuntimeError naming
        how many samples could not be stored if the database keeps failing."""
        self._close_requested.set()
        if self._running:
            await self._stopped.wait()
        for attempt in range(retries + 1):
            await self.flush()
            if not self._queue:
                return
            if attempt < retries:
                await asyncio.sleep(retry_delay_s * (attempt + 1))
        raise RuntimeError(
            f"run {self.run_id}: {len(self._queue)} samples could not be stored "
            f"({self.stats.last_error})"
        )

    def __repr__(self) -> str:
        s = self.stats
        return (
            f"RunRecorder(run={self.run_id}, stored={s.samples_stored}, queued={self.queued}, "
            f"dropped={s.dropped_queue_full}, max_flush_s={s.max_flush_s:.4f})"
        )
