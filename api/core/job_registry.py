"""The jobs of one rig: the live ones in memory, every one in the jobs table.

Each change to a job goes through :meth:`JobRegistry.update`: it is applied under the job's
lock, published to the live stream and written to the database from one writer thread (the
rig loop never waits on the database). A progress change that is neither a new state nor a
new message is written at most every ``SAVE_EVERY_S``.
"""

from __future__ import annotations

import concurrent.futures
import logging
import time
import uuid
from typing import Any

from api.core.job_model import Job, JobNotFound
from api.core.paging import MOST_JOBS
from api.core.service import RigService
from daq.store.faults import one_line
from daq.store.job_repository import JobRepository
from daq.store.schema import JOB_FINAL, JobState

log = logging.getLogger(__name__)

#: Ended jobs kept in memory (all of them stay in the database).
KEEP_ENDED = 500
#: Jobs ``list`` reads from the database, newest first: one page's most.
LIST_LIMIT = MOST_JOBS
#: A progress change that is neither a new state nor a new message is written at most this often.
SAVE_EVERY_S = 1.0


class JobRegistry:
    """This rig's jobs by id, their rows in the database and their live-stream events."""

    def __init__(self, service: RigService) -> None:
        self.service = service
        self.jobs: dict[str, Job] = {}
        self._repo: JobRepository | None = None
        self._saved_at: dict[str, float] = {}
        self._writer = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="job-store")

    @property
    def repo(self) -> JobRepository:
        if self._repo is None:
            if self.service.store is None:
                raise RuntimeError("the rig service is not running")
            self._repo = JobRepository(self.service.store)
        return self._repo

    @property
    def rig_name(self) -> str:
        return self.service.source.rig.rig.name

    def close(self) -> None:
        """Write what is pending, then stop the writer thread."""
        self._writer.shutdown(wait=True)

    # -- writing ---------------------------------------------------------------------------
    def save(self, job: Job, event: bool = False) -> concurrent.futures.Future[None]:
        """Write the job's row (and a progress event) from the writer thread."""
        row = job.row(self.rig_name)
        self._saved_at[job.id] = time.monotonic()

        def write() -> None:
            try:
                self.repo.save(job.id, row)
                if event:
                    self.repo.add_event(
                        job.id, row["state"], row["fraction"], row["message"], time.time()
                    )
            except Exception as err:  # the job goes on; its row catches up on the next save
                log.error("job %s: cannot store its state: %s", job.id, one_line(err))

        return self._writer.submit(write)

    def flush(self, timeout_s: float = 10.0) -> None:
        """Wait until every write asked for so far is done."""
        self._writer.submit(lambda: None).result(timeout_s)

    def delete(self, job: Job) -> None:
        """Forget a job that never ran, here and in the database (waits for the delete)."""
        self.jobs.pop(job.id, None)
        self._writer.submit(lambda: self.repo.delete(job.id)).result(10)

    def publish(self, job: Job) -> None:
        """Show the job's present state on the live stream."""
        self.service.broadcaster.publish_job(job.to_json())

    def new(self, kind: str, label: str, parameters: dict[str, Any], **fields: Any) -> Job:
        """A new job, kept in memory (the oldest ended ones beyond ``KEEP_ENDED`` leave it)."""
        job = Job(uuid.uuid4().hex[:12], kind, label, parameters, **fields)
        self.jobs[job.id] = job
        ended = [j for j in list(self.jobs.values()) if j.state in JOB_FINAL]  # snapshot: threads
        for old in sorted(ended, key=lambda j: j.created_at)[: max(0, len(ended) - KEEP_ENDED)]:
            self.jobs.pop(old.id, None)  # it stays in the database
            self._saved_at.pop(old.id, None)
        return job

    def adopt(self, job: Job) -> None:
        """Keep a job read back from the database (a queued one, at start)."""
        self.jobs[job.id] = job

    def update(self, job: Job, **changes: Any) -> None:
        """Change ``job`` (a final state sets its end time once), publish it, store it."""
        with job.lock:
            before = (job.state, job.message)
            if "state" in changes:
                changes["state"] = JobState(changes["state"])
                if changes["state"] in JOB_FINAL and job.finished_at is None:
                    # ended and its end time in one change: no reader sees one without the other
                    changes.setdefault("finished_at", time.time())
            if job.finished_at is not None:
                changes.pop("finished_at", None)  # a job ends once; its end time stays
            for name, value in changes.items():
                setattr(job, name, value)
            event = (job.state, job.message) != before
            if job.state in JOB_FINAL:
                job.ended.set()
        self.publish(job)
        due = time.monotonic() - self._saved_at.get(job.id, 0.0) >= SAVE_EVERY_S
        if event or due or set(changes) - {"fraction", "message"}:
            self.save(job, event=event)

    # -- reading ---------------------------------------------------------------------------
    def get(self, job_id: str) -> Job:
        """The job ``job_id`` of this rig, live or from the database (``JobNotFound``)."""
        job = self.jobs.get(job_id)
        if job is None:
            row = self.repo.get(job_id) if self.service.store is not None else None
            if row is None or row["rig_name"] != self.rig_name:
                raise JobNotFound(f"no job with id {job_id!r}")
            job = Job.from_row(row)
        return job

    def find(
        self, *, limit: int = LIST_LIMIT, offset: int = 0, state: str | None = None
    ) -> list[Job]:
        """This rig's jobs, newest first (``offset`` of them skipped, at most ``limit``, only
        those in ``state`` if given): the database's, live ones as this process sees them."""
        found: dict[str, Job] = {}
        if self.service.store is not None:
            stored = self.repo.list_jobs(self.rig_name, state=state, limit=offset + limit)
            found = {r["id"]: Job.from_row(r) for r in stored}
        found |= {k: j for k, j in self.jobs.items() if state is None or j.state == state}
        newest = sorted(found.values(), key=lambda j: j.created_at, reverse=True)
        return newest[offset : offset + limit]

    def events(self, job_id: str) -> list[dict[str, Any]]:
        """A job's stored progress events, oldest first."""
        self.get(job_id)
        self.flush()  # what is pending is written first
        return self.repo.events(job_id)
