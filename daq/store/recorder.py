"""The hand-off between the acquisition clock and the database.

The clock's consumer calls :meth:`RunRecorder.put` (never waits); :meth:`RunRecorder.run`
writes whatever is queued at least every ``flush_interval_s`` (≤ 1 s) in a worker thread,
so the event loop never blocks on SQLite or PostgreSQL. A failed write keeps its samples
queued and is retried at the next flush; samples whose (run, seq) is already stored are
dropped and counted, the rest of their batch is kept.

A write that no retry can cure (disk full, I/O error, a read-only database) is a storage
fault: ``on_fault`` is called once with a one-line message (the procedure stops the rig),
and from then on everything unstored is also appended to the run's spill file
(:mod:`daq.store.spill`), written back when a flush succeeds again or on the next open.

:meth:`RunRecorder.end` decides the run's end (status, reason, and the stop time: when it
is called, i.e. when the run ended on the rig) and makes it the store's answer at once
(:mod:`daq.store.pending_ends`), then writes it with a bounded retry. A database that only
delays (a lock held longer than the ``retry_for_s`` limit) is not a fault: what it did not
take, and the end, go to the spill file and are written back later, and the run keeps its
status. Only samples that are lost, or a fault (disk full, I/O error), change it.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import time
from collections import deque
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from daq.sample import Sample
from daq.store import checks
from daq.store.faults import STORE_RETRY_S, StorageFault, describe, one_line
from daq.store.run_records import DuplicateSample
from daq.store.spill import PendingEvent, SpillFile
from daq.store.store import Store

__all__ = ["STORE_RETRY_S", "RecorderStats", "RunRecorder"]

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
    samples_spilled: int = 0
    spill_error: str | None = None

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict."""
        return asdict(self)


class RunRecorder:
    """Batches samples (and events) of one run into the store, flushing at least every
    ``flush_interval_s`` seconds; at most ``max_queue`` samples wait in memory (more are
    dropped and counted, so a stuck database can never exhaust memory or stall the clock).
    ``on_fault`` is called once with a one-line message on the first storage fault;
    unstored samples then also go to the spill file in ``spill_dir`` (default: the
    store's). ``retry_for_s`` (default: the store's, :data:`STORE_RETRY_S` unless set
    otherwise) bounds how long the end of the run waits on a database that
    delays writes before spilling them."""

    def __init__(
        self,
        store: Store,
        run_id: str,
        *,
        flush_interval_s: float = 0.5,
        max_queue: int = 100_000,
        max_batch: int = 50_000,
        spill_dir: Path | None = None,
        on_fault: Callable[[str], None] | None = None,
        retry_for_s: float | None = None,
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
        self.retry_for_s = float(store.retry_for_s if retry_for_s is None else retry_for_s)
        self.stats = RecorderStats()
        self._queue: deque[Sample] = deque()
        self._events: deque[PendingEvent] = deque()
        self._on_fault = on_fault
        #: The first storage fault (one line), None while storage works.
        self.fault: str | None = None
        self.spill = SpillFile(spill_dir or store.spill_dir, self.run_id)
        self._spilled_seq = -1
        self._close_requested = asyncio.Event()
        self._running = False
        self._stopped = asyncio.Event()
        self._flush_lock = asyncio.Lock()

    @property
    def queued(self) -> int:
        """Samples waiting for the next flush."""
        return len(self._queue)

    @property
    def pending(self) -> int:
        """Samples and events not stored yet."""
        return len(self._queue) + len(self._events)

    def put(self, sample: Sample) -> None:
        """Queue one sample; never blocks (drops and counts it when the queue is full, which
        is a storage fault: the database has fallen that far behind)."""
        if len(self._queue) >= self.max_queue:
            self.stats.dropped_queue_full += 1
            if self.stats.dropped_queue_full == 1:
                log.error("run %s: recorder queue full (%d); dropping", self.run_id, self.max_queue)
                self._set_fault(
                    f"storage failed: {self.max_queue} samples waiting "
                    f"({self.stats.last_error or 'the database is too slow'})"
                )
            return
        self._queue.append(sample)

    def add_event(self, kind: str, message: str, data: dict[str, Any] | None = None) -> None:
        """Queue an event of this run (time: now); stored with the next flush, never waits."""
        checks.check_kind("kind", kind)
        if not isinstance(message, str) or not message.strip():
            raise ValueError(f"message: {message!r} is not allowed; give a non-empty text")
        checks.check_json("data", data, optional=True)
        self._events.append(PendingEvent(kind, message, data, time.time()))

    def _set_fault(self, message: str) -> None:
        """Record the first storage fault and tell ``on_fault`` (once)."""
        if self.fault is not None:
            return
        self.fault = message
        log.error("run %s: %s", self.run_id, message)
        if self._on_fault is not None:
            try:
                self._on_fault(message)
            except Exception:
                log.exception("run %s: on_fault callback failed", self.run_id)

    def _failed(self, exc: BaseException) -> None:
        err = describe(exc)
        self.stats.failed_flushes += 1
        self.stats.last_error = err.message
        if err.retryable:
            log.warning("run %s: flush failed, will retry: %s", self.run_id, err.message)
        else:
            self._set_fault(f"storage failed: {err.message}")

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

    def _write_samples(self, batch: list[Sample]) -> int:
        try:
            return self.store.add_samples(self.run_id, batch)
        except DuplicateSample as exc:  # keep the new samples, drop the repeats
            self.stats.last_error = str(exc)
            log.error("%s", exc)
            written = self.store.add_samples(self.run_id, batch, skip_existing=True)
            self.stats.discarded_duplicates += len(batch) - written
            return written

    def _write_events(self, events: list[PendingEvent]) -> None:
        for e in events:
            self.store.add_event(self.run_id, e.kind, e.message, e.data, t_wall=e.t_wall)
            self._events.remove(e)

    async def flush(self) -> int:
        """Write everything queued now; returns how many samples were stored. After a
        storage fault, what could not be written is also appended to the spill file."""
        stored = 0
        async with self._flush_lock:
            failed = False
            while self._queue:
                count = min(len(self._queue), self.max_batch)
                batch = [self._queue.popleft() for _ in range(count)]
                started = time.perf_counter()
                try:
                    written = await asyncio.to_thread(self._write_samples, batch)
                except Exception as exc:
                    self._queue.extendleft(reversed(batch))
                    self._failed(exc)
                    failed = True
                    break
                elapsed = time.perf_counter() - started
                self.stats.samples_stored += written
                self.stats.batches += 1
                self.stats.last_flush_s = elapsed
                self.stats.max_flush_s = max(self.stats.max_flush_s, elapsed)
                stored += written
            if self._events and not failed:
                try:
                    await asyncio.to_thread(self._write_events, list(self._events))
                except Exception as exc:
                    self._failed(exc)
            if self.fault is not None:
                await self._spill_pending()
        return stored

    async def _spill_pending(self) -> None:
        """Append what is queued and not yet in the spill file (in a worker thread)."""
        samples = [s for s in self._queue if s.seq > self._spilled_seq]
        events = [e for e in self._events if not e.spilled]
        if not samples and not events:
            return
        try:
            await asyncio.to_thread(self.spill.append, samples, events)
        except OSError as exc:
            if self.stats.spill_error is None:
                log.error(
                    "run %s: cannot write spill file %s: %s", self.run_id, self.spill.path, exc
                )
            self.stats.spill_error = one_line(exc)
            return
        self.stats.spill_error = None
        if samples:
            self._spilled_seq = samples[-1].seq
        for e in events:
            e.spilled = True
        self.stats.samples_spilled += len(samples)

    async def close(self, *, retry_for_s: float | None = None, fault_retries: int = 3) -> None:
        """Stop :meth:`run` and store everything still queued.

        Retryable errors (a lock held by another connection, a dropped connection) are
        retried with a backoff of 0.1 s doubling to 2 s for up to ``retry_for_s`` (default:
        the recorder's); after a storage fault (disk full, I/O error) ``fault_retries`` more
        times. Raises :class:`StorageFault` (one line) if samples or events are still
        unstored; they are then in the spill file (see :mod:`daq.store.spill`), written back
        later. Only a spill file that cannot be written either makes this a fault.
        """
        self._close_requested.set()
        if self._running:
            await self._stopped.wait()
        limit_s = self.retry_for_s if retry_for_s is None else retry_for_s
        loop = asyncio.get_running_loop()
        give_up_at = loop.time() + limit_s
        delay, attempts = 0.1, 0
        while True:
            await self.flush()
            if not self.pending:
                break
            attempts += 1
            if (self.fault is not None and attempts > fault_retries) or loop.time() >= give_up_at:
                break
            await asyncio.sleep(delay)
            delay = min(2 * delay, 2.0)
        if not self.pending:
            self.spill.close(remove=True)  # all it held is in the database now
            return
        await self._spill_pending()
        if self.stats.spill_error is not None:  # neither stored nor kept: lost
            self._set_fault(
                f"storage failed: {self.stats.last_error} (gave up after {limit_s:g} s)"
            )
        where = (
            f"kept in {self.spill.path}"
            if self.stats.spill_error is None
            else f"NOT kept ({self.stats.spill_error})"
        )
        raise StorageFault(
            f"run {self.run_id}: {len(self._queue)} samples and {len(self._events)} events "
            f"not stored ({self.stats.last_error}); {where}"
        )

    @property
    def lost(self) -> bool:
        """Samples of the run are neither stored nor in the spill file."""
        unkept = bool(self._queue) and self.stats.spill_error is not None
        return self.stats.dropped_queue_full > 0 or unkept

    async def end(
        self, status: str, reason: str | None, *, stopped_at: float | None = None
    ) -> tuple[str, str | None]:
        """Close, then write the run's end once, truthfully; returns the (status, reason)
        written (or kept in the spill file, written back later).

        ``stopped_at`` (Unix s, default: now, when the procedure hands over) is stored as
        the run's stop time whenever the database takes it. Until then the store answers
        with this end (:mod:`daq.store.pending_ends`). A storage fault that leaves samples
        unstored turns ``completed`` into ``aborted`` (the fault is the reason) and is
        added to another reason; a database that only delays the writes (a lock, however
        long) never changes the status: what it did not take in ``retry_for_s`` is spilled.
        """
        stopped_at = time.time() if stopped_at is None else stopped_at
        self.store.pending_ends.set(self.run_id, status, reason, stopped_at)
        with contextlib.suppress(StorageFault):
            await self.close()
        if self.fault is not None:
            if status == "completed":
                if self._queue or self.lost:  # samples not stored
                    status, reason = "aborted", self.fault
                # else only events wait (in the spill file): the run stays completed
            elif reason and self.fault not in reason:
                reason = f"{reason}; {self.fault}"
            elif not reason:
                reason = self.fault
            self.store.pending_ends.set(self.run_id, status, reason, stopped_at)
        if self.pending:  # the rest waits in the spill file: the end goes after it
            await self._spill_end(status, reason, stopped_at)
            return status, reason
        loop = asyncio.get_running_loop()
        give_up_at = loop.time() + self.retry_for_s
        delay, attempts = 0.1, 0
        while True:
            try:
                await asyncio.to_thread(
                    self.store.finish_run, self.run_id, status, reason, stopped_at=stopped_at
                )
                break
            except ValueError:
                # "already ended": an earlier attempt may have committed before its error.
                if attempts and self.store.get_run(self.run_id, as_stored=True).status == status:
                    self.store.pending_ends.discard(self.run_id)
                    break
                raise  # a wrong status, or a run someone else ended: a bug, not storage
            except Exception as exc:
                if not isinstance(exc, sa.exc.SQLAlchemyError | OSError):
                    raise
                err = describe(exc)
                attempts += 1
                self.stats.last_error = err.message
                if (not err.retryable and attempts > 3) or loop.time() >= give_up_at:
                    log.error(
                        "run %s: cannot write its end (%s); kept in %s for the next open",
                        self.run_id,
                        err.message,
                        self.spill.path,
                    )
                    await self._spill_end(status, reason, stopped_at)
                    return status, reason
                await asyncio.sleep(delay)
                delay = min(2 * delay, 2.0)
        return status, reason

    async def _spill_end(self, status: str, reason: str | None, stopped_at: float) -> None:
        """Append the run's end to the spill file and release it (written back later)."""
        try:
            await asyncio.to_thread(self.spill.append, end=(status, reason, stopped_at))
        except OSError as spill_exc:
            log.error(
                "run %s: cannot write spill file either (%s); it will show as "
                "interrupted at the next start-up",
                self.run_id,
                one_line(spill_exc),
            )
        self.spill.close(remove=False)

    def __repr__(self) -> str:
        s = self.stats
        return (
            f"RunRecorder(run={self.run_id}, stored={s.samples_stored}, queued={self.queued}, "
            f"dropped={s.dropped_queue_full}, max_flush_s={s.max_flush_s:.4f})"
        )
