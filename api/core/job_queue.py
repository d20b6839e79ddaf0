"""The rig's queue: which procedure job holds the rig, which wait, and whether the queue may
start the next one by itself.

A procedure asked for while the rig is busy (or while jobs wait, or the queue is paused)
waits here with a ``position`` 1, 2, …; with ``queue=False`` it is refused at once
(``JobConflict``, HTTP 409) naming the holder. When the rig frees, the first waiting job is
handed to the ``start`` callback (the rig worker). A job that ends other than ``completed``
while others wait pauses the queue, as do an emergency stop and a service start that finds
queued jobs: the rig never moves by itself after something went wrong; an operator resumes
the queue. Every field below is read and changed under :attr:`RigQueue.lock` only.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from api.core.job_model import Job, JobConflict
from api.core.job_registry import JobRegistry
from daq.store.faults import one_line
from daq.store.schema import JOB_ACTIVE, JobState

#: Jobs that may wait in the rig's queue: the one registry a client could otherwise grow
#: without end (a start beyond it is refused, 409).
MAX_QUEUED = 100


class RigQueue:
    """The job on the rig and the jobs waiting for it.

    ``start(job)`` is called (outside the lock) with a job the queue just put on the rig;
    ``refusal(job)`` says why a waiting job may not start now (an unacknowledged emergency
    stop, a hold by someone else) or None.
    """

    def __init__(
        self,
        registry: JobRegistry,
        start: Callable[[Job], None],
        refusal: Callable[[Job], JobConflict | None],
    ) -> None:
        self.registry = registry
        self._start = start
        self._refusal = refusal
        self.lock = threading.Lock()
        self._waiting: list[Job] = []
        #: Why the queue does not start its next job by itself (None: it does).
        self._paused: str | None = None
        self._holder: Job | None = None
        self._closing = False
        #: Set while no job holds the rig (``close`` waits on it).
        self.idle = threading.Event()
        self.idle.set()

    # -- reading -----------------------------------------------------------------------------
    @property
    def holder(self) -> Job | None:
        """The job the queue put on the rig, until it leaves it (ended or not)."""
        return self._holder

    @property
    def running(self) -> Job | None:
        """The procedure job holding the rig, if it has not ended."""
        job = self._holder
        return job if job is not None and job.state in JOB_ACTIVE else None

    def __contains__(self, job: object) -> bool:
        return job in self._waiting

    def __len__(self) -> int:
        return len(self._waiting)

    def queued(self, job_id: str) -> Job:
        """The waiting job ``job_id`` (``JobConflict`` if it does not wait)."""
        job = self.registry.get(job_id)
        if job not in self._waiting:
            raise JobConflict(f"job {job.id} is not in the queue (state {job.state})")
        return job

    def to_json(self) -> dict[str, Any]:
        """The rig's queue: paused or not (and why), the job on the rig, the waiting jobs."""
        with self.lock:
            waiting = list(self._waiting)
            paused = self._paused
        running = self.running
        return {
            "paused": paused is not None,
            "reason": paused,
            "running": running.to_json() if running is not None else None,
            "jobs": [j.to_json() for j in waiting],
        }

    # -- taking the rig ------------------------------------------------------------------------
    def admit(self, make: Callable[[], Job], *, queue: bool, lock_holder: str | None) -> Job:
        """``make()`` a job and put it on the rig if the rig is free and nothing waits, else
        at the end of the queue (``position`` set). Refused (``JobConflict``) when someone
        outside this service holds the rig lock, when the queue is full, and with
        ``queue=False`` whenever it would wait."""
        with self.lock:
            busy = self.running
            if lock_holder is not None and busy is None:
                raise JobConflict(
                    f"rig is busy: {lock_holder} holds the rig lock", holder=lock_holder
                )
            if busy is None and not self._waiting and not self._paused:
                job = make()
                self._hold(job)
                return job
            if not queue:  # a paused queue holds a new job too
                raise self._would_wait(busy)
            if len(self._waiting) >= MAX_QUEUED:
                raise JobConflict(
                    f"the rig's queue is full: {len(self._waiting)} jobs wait (at most "
                    f"{MAX_QUEUED}); remove some (DELETE /api/queue/{{id}}) or let them run",
                    holder="the rig's queue",
                )
            job = make()
            self._waiting.append(job)
            self._renumber()
            return job

    def _would_wait(self, busy: Job | None) -> JobConflict:
        """Why a job that may not wait cannot start now (caller holds ``lock``)."""
        if busy is not None:
            return JobConflict(
                f"rig is busy: job {busy.id} ({busy.label}) holds the rig lock",
                holder=f"{busy.label} (job {busy.id})",
            )
        if not self._waiting:
            return JobConflict(
                f"the rig's queue is paused ({self._paused}): resume it first",
                holder="the rig's queue",
            )
        return JobConflict(
            f"rig is free but {len(self._waiting)} job(s) wait in its queue "
            f"(queue {'paused' if self._paused else 'starting'})",
            holder="the rig's queue",
        )

    def _hold(self, job: Job | None) -> None:
        """``job`` holds the rig now (None: nothing does); caller holds ``lock``."""
        self._holder = job
        if job is None:
            self.idle.set()
        else:
            self.idle.clear()

    def vacate(self, job: Job, pause: str | None = None) -> None:
        """``job`` no longer holds the rig (if it did); ``pause`` the queue with that reason."""
        with self.lock:
            if self._holder is job:
                self._hold(None)
            if pause is not None:
                self._paused = pause

    def rig_freed(self, job: Job) -> None:
        """``job`` left the rig: pause the queue if it did not complete and others wait
        (the first reason stays, an e-stop's say), else start the next."""
        with self.lock:
            if self._holder is job:
                self._hold(None)
            paused = self._paused is not None
            if job.state != JobState.COMPLETED and self._waiting and not (paused or self._closing):
                self._paused = (
                    f"job {job.id} ({job.label}) ended {job.state}: "
                    "resume the queue to run the next job"
                )
        self.start_next()

    def start_next(self) -> None:
        """Start the first waiting job if the rig is free and the queue is not paused."""
        with self.lock:
            if self._closing or self._paused or self.running is not None or not self._waiting:
                return
            try:
                refused = self._refusal(self._waiting[0])
            except Exception as err:  # fail safe: no start without the safety log
                refused = JobConflict(f"the safety log cannot be read: {one_line(err)}")
            if refused is not None:
                self._paused = f"{refused}; then resume the queue"
                return
            job = self._waiting.pop(0)
            self._hold(job)
            job.position = None
            self._renumber()
        self._start(job)

    def close(self) -> None:
        """Start no further job (the waiting ones stay queued in the database)."""
        with self.lock:
            self._closing = True

    # -- editing (called from HTTP threads) ---------------------------------------------------
    def restore(self, jobs: list[Job], reason: str) -> None:
        """Put ``jobs`` (read back from the database) at the end of the queue, paused with
        ``reason`` if any wait."""
        with self.lock:
            self._waiting.extend(j for j in jobs if j not in self._waiting)
            if self._waiting:
                self._paused = reason
            self._renumber()

    def move(self, job_id: str, position: int) -> None:
        """Put a waiting job at ``position`` (1 = next to run)."""
        with self.lock:
            job = self.queued(job_id)
            if not 1 <= position <= len(self._waiting):
                raise ValueError(
                    f"position: {position} is outside the queue; allowed 1 ≤ position ≤ "
                    f"{len(self._waiting)}"
                )
            self._waiting.remove(job)
            self._waiting.insert(position - 1, job)
            self._renumber()
        self.registry.flush()

    def remove(self, job_id: str) -> Job:
        """Take a waiting job out of the queue and forget it (it never ran)."""
        with self.lock:
            job = self.queued(job_id)
            self._waiting.remove(job)
            self._renumber()
        self.registry.delete(job)
        return job

    def discard(self, job: Job) -> bool:
        """Take ``job`` out of the queue if it waits there (aborted while queued)."""
        with self.lock:
            if job not in self._waiting:
                return False
            self._waiting.remove(job)
            self._renumber()
            return True

    def pause(self, reason: str) -> None:
        """Start no further waiting job (the one on the rig goes on)."""
        with self.lock:
            self._paused = reason

    def pause_if_waiting(self, reason: str) -> None:
        """Pause the queue if jobs wait (an empty queue is not held: the next start runs)."""
        with self.lock:
            if self._waiting:
                self._paused = reason

    def resume(self) -> None:
        """Let the queue start its jobs again, the first one now if the rig is free."""
        with self.lock:
            self._paused = None
        self.start_next()

    def _renumber(self) -> None:
        """Positions 1, 2, … in queue order (caller holds ``lock``); saved in the background."""
        for position, queued in enumerate(self._waiting, start=1):
            if queued.position != position:
                queued.position = position
                queued.message = f"queued (position {position})"
                self.registry.save(queued)
