"""Jobs: the runner the HTTP routes and the CLI call, made of parts that each own one thing.

* :class:`~api.core.job_registry.JobRegistry` — the jobs by id, their rows in the jobs
  table (written from one writer thread) and their live-stream events;
* :class:`~api.core.job_queue.RigQueue` — the job on the rig, the jobs waiting for it, and
  whether the queue may start the next one (a start callback hands it to the rig worker);
* :class:`~api.core.rig_worker.RigWorker` — procedures on the rig's loop, the operator
  bridge, the controls of a running job and the emergency stop;
* :class:`~api.core.analysis_worker.AnalysisWorker` — estimations and cross-checks one at a
  time, fitted in a worker process (``api.core.analysis_executor``), and their report figures.

States are :class:`daq.store.schema.JobState`: ``queued → running ⇄ waiting_for_operator |
paused → completed | aborted | failed``, ``interrupted`` when the service died while the job
ran (marked at the next start).

Concurrency: threads that share memory. Callers come from any thread (HTTP workers, the rig
loop's thread, the analysis and writer threads); each part guards its mutable state with its
own lock (the queue's ``lock``, each job's ``lock``) and holds it only while it changes
that state, never while waiting for another thread (the one blocking call under the queue's
lock is the read of the safety log before a queued job starts). The two things that are not plain
memory each have one owner thread: the asyncio objects of a running procedure live on the
rig loop (reached through ``RigService.call_soon``), and the database is written by the
registry's writer thread. Waiting is on events and futures: :meth:`JobRunner.close` waits on
the queue's ``idle`` event and the workers' futures, never in a sleep loop.
"""

from __future__ import annotations

import builtins
import contextlib
import logging
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from api.core.analysis_worker import ANALYSES, REPORT_SUFFIXES, AnalysisWorker
from api.core.job_model import Job, JobConflict, JobNotFound
from api.core.job_queue import RigQueue
from api.core.job_registry import LIST_LIMIT, JobRegistry
from api.core.queue_edits import QueueEdits
from api.core.rig_worker import PROCEDURES, RigWorker
from api.core.service import RigService
from daq.store.job_repository import JobRepository
from daq.store.schema import JOB_ACTIVE, JOB_FINAL

log = logging.getLogger(__name__)

ACTIVE = JOB_ACTIVE
FINAL = JOB_FINAL

__all__ = [
    "ACTIVE",
    "FINAL",
    "LIST_LIMIT",
    "PROCEDURES",
    "REPORT_SUFFIXES",
    "Job",
    "JobConflict",
    "JobNotFound",
    "JobRunner",
]


class JobRunner(QueueEdits):
    """Starts, tracks, queues and stops jobs for one ``RigService`` (queue editing beyond
    move/remove: :class:`api.core.queue_edits.QueueEdits`)."""

    def __init__(self, service: RigService, *, report_root: Path | None = None) -> None:
        self.service = service
        self.registry = JobRegistry(service)
        self._own_report_root = report_root is None
        #: Scratch space where reports are drawn before they are stored in the database.
        self.report_root = report_root or Path(tempfile.mkdtemp(prefix="towrig-reports-"))
        self.rig = RigWorker(service, self.registry)
        self.queue: RigQueue = self.rig.queue
        self.analysis = AnalysisWorker(self.registry, self.report_root)
        #: Called by :meth:`close` once the rig is free, before the analysis worker and
        #: the registry close: parts that run in threads of their own (campaigns) end
        #: and write their ending here.
        self.before_close: list[Callable[[], None]] = []

    def start_procedure(self, kind: str, params: Any, label: str, **options: Any) -> Job:
        """Start a validated procedure or queue it (:meth:`RigWorker.start_procedure`, its
        options), for the routes, campaigns and queue edits; then start the server the
        analysis worker forks from, if not yet (``AnalysisWorker.prepare``): a test's runs
        are what is estimated next, so its imports overlap the test."""
        job = self.rig.start_procedure(kind, params, label, **options)
        if self.service.store is not None:
            self.analysis.prepare(self.service.store)
        return job

    @property
    def jobs(self) -> dict[str, Job]:
        """The jobs this process knows, by id."""
        return self.registry.jobs

    @property
    def repo(self) -> JobRepository:
        return self.registry.repo

    @property
    def rig_name(self) -> str:
        return self.registry.rig_name

    @property
    def rig_job(self) -> Job | None:
        """The procedure job holding the rig, if any."""
        return self.queue.running

    def open(self) -> None:
        """After the service started: mark jobs a dead service left running ``interrupted``,
        take back the queue, paused until an operator resumes it. Neither the analysis
        worker nor the server it forks from starts here (an idle service holds neither:
        :meth:`start_procedure`, ``AnalysisWorker.prepare``)."""
        recovered = self.repo.recover_interrupted(self.rig_name)
        if recovered:
            log.warning("marked %d job(s) interrupted: %s", len(recovered), ", ".join(recovered))
        waiting = []
        for row in self.repo.queued(self.rig_name):
            if row["id"] not in self.jobs:
                job = Job.from_row(row)
                self.registry.adopt(job)
                waiting.append(job)
        count = len(self.queue) + len(waiting)
        self.queue.restore(
            waiting,
            f"the service started with {count} job(s) queued: resume the queue to run them",
        )

    def close(self, *, timeout_s: float = 15.0) -> None:
        """Abort running procedures (their runs end ``aborted``, the rig safe) and wait until
        the rig is free; queued jobs stay queued in the database."""
        self.queue.close()
        for job in self.rig.on_rig():
            with contextlib.suppress(Exception):
                self.abort(job.id, "service stopped")
        if not self.queue.idle.wait(timeout_s):
            log.warning("a job still held the rig %.0f s after the service stopped", timeout_s)
        for close in self.before_close:
            close()
        self.analysis.close()
        self.registry.close()
        if self._own_report_root:
            shutil.rmtree(self.report_root, ignore_errors=True)

    # -- the registry -----------------------------------------------------------------------
    def get(self, job_id: str) -> Job:
        """The job ``job_id`` of this rig, live or from the database (``JobNotFound``)."""
        return self.registry.get(job_id)

    def events(self, job_id: str) -> builtins.list[dict[str, Any]]:
        """A job's stored progress events, oldest first."""
        return self.registry.events(job_id)

    # -- procedures and the rig --------------------------------------------------------------
    def abort(self, job_id: str, reason: str = "operator abort (API)") -> Job:
        """Abort a job, queued or running: a procedure (:meth:`RigWorker.abort`), an
        estimation or a cross-check (:meth:`AnalysisWorker.abort`)."""
        job = self.get(job_id)
        if job.kind in ANALYSES:
            return self.analysis.abort(job, reason)
        return self.rig.abort(job_id, reason)

    def pause(self, job_id: str) -> Job:
        """Pause a sequence after the step in progress."""
        return self.rig.pause(job_id)

    def resume(self, job_id: str) -> Job:
        """Resume a paused sequence."""
        return self.rig.resume(job_id)

    def confirm(self, job_id: str) -> Job:
        """Confirm the operator act a job waits for."""
        return self.rig.confirm(job_id)

    def emergency_stop(self, user: str | None = None) -> builtins.list[str]:
        """Abort the job on the rig, hold the queue, latch the stop (:class:`RigWorker`)."""
        return self.rig.emergency_stop(user)

    # -- the queue (called from HTTP threads) -------------------------------------------------
    def queue_json(self) -> dict[str, Any]:
        """The rig's queue: paused or not (and why), the job on the rig, the waiting jobs."""
        return self.queue.to_json()

    def move(self, job_id: str, position: int) -> dict[str, Any]:
        """Put a queued job at ``position`` (1 = next to run)."""
        self.queue.move(job_id, position)
        return self.queue_json()

    def remove(self, job_id: str) -> dict[str, Any]:
        """Take a job out of the queue and forget it (it never ran)."""
        self.queue.remove(job_id)
        return self.queue_json()

    def pause_queue(self, reason: str = "paused by the operator (API)") -> dict[str, Any]:
        """Start no further queued job (the one on the rig goes on)."""
        self.queue.pause(reason)
        return self.queue_json()

    def resume_queue(self) -> dict[str, Any]:
        """Let the queue start its jobs again, the first one now if the rig is free."""
        self.queue.resume()
        return self.queue_json()

    # -- analysis (estimation, cross-check, reports) ------------------------------------------
    def start_estimation(
        self,
        run_ids: builtins.list[str],
        method: str,
        search_effects: bool,
        user: str | None = None,
        exclude_outliers: bool = False,
    ) -> Job:
        """Run an estimation in the analysis worker (:class:`AnalysisWorker`)."""
        return self.analysis.start_estimation(
            run_ids, method, search_effects, user, exclude_outliers
        )

    def start_crosscheck(
        self,
        weight_runs: builtins.list[str],
        thruster_runs: builtins.list[str],
        search_effects: bool = True,
        user: str | None = None,
    ) -> Job:
        """Estimate both sets of runs and cross-check them, in the analysis worker."""
        return self.analysis.start_crosscheck(weight_runs, thruster_runs, search_effects, user)

    def adopt_report(self, result_id: int, folder: Path) -> builtins.list[str]:
        """Store ``folder``'s figures as the report of ``result_id``; the figure names."""
        return self.analysis.adopt_report(result_id, folder)

    def report_names(self, result_id: int) -> builtins.list[str]:
        """Names of the report figures stored with ``result_id``."""
        return self.analysis.report_names(result_id)

    def report_contents(self, result_id: int) -> builtins.list[tuple[str, bytes]]:
        """Every stored file of a result's report (report.md and the figures), by name."""
        return self.analysis.report_contents(result_id)

    def report_file(
        self, result_id: int, name: str, suffix: str = ".png"
    ) -> tuple[str, bytes] | None:
        """``(media type, bytes)`` of a result's report figure ``name``, if stored."""
        return self.analysis.report_file(result_id, name, suffix)

    def list(
        self, *, limit: int = LIST_LIMIT, offset: int = 0, state: str | None = None
    ) -> builtins.list[Job]:
        """This rig's jobs, newest first (:meth:`JobRegistry.find`)."""
        return self.registry.find(limit=limit, offset=offset, state=state)
