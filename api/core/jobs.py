"""Jobs: procedures on the rig loop, estimations in a worker thread, one registry kept in
the database, and the rig's queue.

A procedure job (tow, spin, pendulum, thrust calibration, sequence) holds the rig for its whole
life. Starting one while the rig is busy puts it in the rig's queue (``queued`` with a
``position``; with ``queue=False`` it is refused at once, HTTP 409, naming the holder). Queued
jobs start in order as the rig frees. A job that ends other than ``completed`` (aborted,
failed) while others wait pauses the queue, as do an emergency stop and a service start that
find queued jobs: the rig never moves by itself after something went wrong, an operator
resumes the queue. A job started while the queue is paused waits in it. States
(:class:`daq.store.schema.JobState`): ``queued → running ⇄ waiting_for_operator |
paused → completed | aborted | failed``, ``interrupted`` when the service died while the
job ran (marked at the next start). Every change is published to the live stream and
written to the jobs table (from one writer thread: the rig loop never waits on the
database); report files of estimations are stored with their result.

The registry and its database writer are :mod:`api.core.job_registry`; estimations and
cross-checks run in :mod:`api.core.analysis_worker`.
"""

from __future__ import annotations

import asyncio
import builtins
import contextlib
import dataclasses
import logging
import shutil
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from api.core.analysis_worker import REPORT_SUFFIXES, AnalysisWorker
from api.core.job_model import Job, JobConflict, JobNotFound
from api.core.job_registry import LIST_LIMIT, JobRegistry
from api.core.job_requests import procedure_from_request
from api.core.queue_edits import QueueEdits
from api.core.rig_guard import RigGuard, latching_stop
from api.core.service import RigService
from daq.operator import OperatorAct
from daq.procedures.kinds import KINDS
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal
from daq.procedures.sequence import Sequence, SequenceControl
from daq.rig_lock import RigLockLost
from daq.session import Aborted, RigBusy
from daq.store.faults import StorageFault, one_line
from daq.store.jobs import JobRepository
from daq.store.schema import JOB_ACTIVE, JOB_FINAL, JobState

log = logging.getLogger(__name__)

ACTIVE = JOB_ACTIVE
FINAL = JOB_FINAL
#: Jobs that hold the rig: one per run kind, and sequences of them.
PROCEDURES = (*KINDS, "sequence")
#: Jobs that may wait in the rig's queue: the one registry a client could otherwise grow
#: without end (a start beyond it is refused, 409).
MAX_QUEUED = 100

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


def run_metadata(job: Job) -> dict[str, Any]:
    """The metadata a procedure job puts on its runs: its request's, then who started it
    and the job (``started_by``, ``job_id``; a sequence adds itself and the step)."""
    from daq.store.run_metadata import check_run_metadata

    meta = check_run_metadata((job.request or {}).get("metadata"))
    return meta | {"job_id": job.id} | ({"started_by": job.user_name} if job.user_name else {})


class JobRunner(QueueEdits):
    """Starts, tracks, queues and stops jobs for one ``RigService`` (queue editing beyond
    move/remove: :class:`api.core.queue_edits.QueueEdits`)."""

    def __init__(self, service: RigService, *, report_root: Path | None = None) -> None:
        self.service = service
        self.registry = JobRegistry(service)
        self._lock = threading.Lock()
        self._rig_job: Job | None = None
        self._queue: list[Job] = []
        #: Why the queue does not start its next job by itself (None: it does).
        self._queue_paused: str | None = None
        self._closing = False
        self._own_report_root = report_root is None
        #: Scratch space where reports are drawn before they are stored in the database.
        self.report_root = report_root or Path(tempfile.mkdtemp(prefix="towrig-reports-"))
        self.analysis = AnalysisWorker(self.registry, self.report_root)
        service.operator_hook = self._ask_operator

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

    def get(self, job_id: str) -> Job:
        """The job ``job_id`` of this rig, live or from the database (``JobNotFound``)."""
        return self.registry.get(job_id)

    def events(self, job_id: str) -> builtins.list[dict[str, Any]]:
        """A job's stored progress events, oldest first."""
        return self.registry.events(job_id)

    def open(self) -> None:
        """After the service started: mark jobs a dead service left running ``interrupted``
        and take back the queue, paused until an operator resumes it."""
        recovered = self.repo.recover_interrupted(self.rig_name)
        if recovered:
            log.warning("marked %d job(s) interrupted: %s", len(recovered), ", ".join(recovered))
        with self._lock:
            for row in self.repo.queued(self.rig_name):
                if row["id"] not in self.jobs:
                    job = Job.from_row(row)
                    self.registry.adopt(job)
                    self._queue.append(job)
            if self._queue:
                self._queue_paused = (
                    f"the service started with {len(self._queue)} job(s) queued: "
                    "resume the queue to run them"
                )
            self._renumber()

    def close(self, *, timeout_s: float = 15.0) -> None:
        """Abort running procedures (their runs end ``aborted``, the rig safe) and wait;
        queued jobs stay queued in the database."""
        self._closing = True
        for job in list(self.jobs.values()):
            if job.kind in PROCEDURES and job.state in ACTIVE and job not in self._queue:
                with contextlib.suppress(Exception):
                    self.abort(job.id, "service stopped")
        end = time.monotonic() + timeout_s
        while self.rig_job is not None and time.monotonic() < end:
            time.sleep(0.05)
        self.analysis.close()
        self.registry.close()
        if self._own_report_root:
            shutil.rmtree(self.report_root, ignore_errors=True)

    @property
    def rig_job(self) -> Job | None:
        """The procedure job holding the rig, if any."""
        job = self._rig_job
        return job if job is not None and job.state in ACTIVE else None

    # -- procedures ----------------------------------------------------------------------
    def start_procedure(
        self,
        kind: str,
        params: Any,
        label: str,
        *,
        request: dict[str, Any] | None = None,
        queue: bool = True,
        user: str | None = None,
    ) -> Job:
        """Start a validated procedure, or queue it behind the job holding the rig (and the
        jobs already queued). With ``queue=False`` a busy rig is ``JobConflict`` (→ 409).
        The request's ``metadata`` goes on every run it records (checked here: 422 first).
        ``user`` asked for it: refused while an emergency stop is unacknowledged or someone
        else holds the rig (``api.core.rig_guard``)."""
        from daq.store.run_metadata import check_run_metadata

        check_run_metadata((request or {}).get("metadata"))
        session = self.service.require_session()
        RigGuard.of(self.service).check_start(user)
        parameters = params.to_json()
        note = getattr(params, "adjustment", lambda: None)()
        fields = {"notes": [note] if note else [], "request": request, "params": params}
        fields["user_name"] = user
        with self._lock:
            busy = self.rig_job
            if session.lock_holder is not None and busy is None:
                raise JobConflict(
                    f"rig is busy: {session.lock_holder} holds the rig lock",
                    holder=session.lock_holder,
                )
            if busy is not None or self._queue or self._queue_paused:  # a paused queue holds it
                if not queue:
                    if busy is None and not self._queue:
                        raise JobConflict(
                            f"the rig's queue is paused ({self._queue_paused}): resume it first",
                            holder="the rig's queue",
                        )
                    if busy is None:
                        raise JobConflict(
                            f"rig is free but {len(self._queue)} job(s) wait in its queue "
                            f"(queue {'paused' if self._queue_paused else 'starting'})",
                            holder="the rig's queue",
                        )
                    raise JobConflict(
                        f"rig is busy: job {busy.id} ({busy.label}) holds the rig lock",
                        holder=f"{busy.label} (job {busy.id})",
                    )
                if len(self._queue) >= MAX_QUEUED:
                    raise JobConflict(
                        f"the rig's queue is full: {len(self._queue)} jobs wait (at most "
                        f"{MAX_QUEUED}); remove some (DELETE /api/queue/{{id}}) or let them run",
                        holder="the rig's queue",
                    )
                job = self.registry.new(kind, label, parameters, **fields)
                self._queue.append(job)
                self._renumber()
            else:
                job = self.registry.new(kind, label, parameters, **fields)
                self._rig_job = job
        if job.position is not None:
            # a queued job survives a restart at once
            self.registry.save(job, event=True).result(10)
            self.registry.publish(job)
            return job
        self.registry.save(job, event=True)
        self._submit(job, params)
        return job

    def _submit(self, job: Job, params: Any) -> None:
        try:
            self.service.submit(self._hold_rig(job, params))
        except Exception as err:  # RigUnavailable says why (a lost rig lock, say)
            with self._lock:
                self._rig_job = None
            self.registry.update(job, state="failed", error=one_line(err))
            raise
        self.registry.publish(job)

    async def _hold_rig(self, job: Job, params: Any) -> None:
        """Run a procedure, then hand the rig to the next queued job."""
        try:
            await self._run_procedure(job, job.kind, params)
        finally:
            self._rig_freed(job)

    def _rig_freed(self, job: Job) -> None:
        with self._lock:
            paused = self._queue_paused is not None  # keep the first reason (an e-stop)
            if job.state != JobState.COMPLETED and self._queue and not (paused or self._closing):
                self._queue_paused = (
                    f"job {job.id} ({job.label}) ended {job.state}: "
                    "resume the queue to run the next job"
                )
        self._start_next()

    def _start_next(self) -> None:
        """Start the first queued job if the rig is free and the queue is not paused."""
        with self._lock:
            if self._closing or self._queue_paused or self.rig_job is not None:
                return
            if not self._queue:
                return
            try:
                refused = RigGuard.of(self.service).refusal(self._queue[0].user_name)
            except Exception as err:  # fail safe: no start without the safety log
                refused = JobConflict(f"the safety log cannot be read: {one_line(err)}")
            if refused is not None:  # an unacknowledged e-stop, a hold by someone else
                self._queue_paused = f"{refused}; then resume the queue"
                return
            job = self._queue.pop(0)
            self._rig_job = job
            job.position = None
            self._renumber()
        params = job.params
        if params is None:  # queued before a restart: rebuilt as the route built it
            try:
                params, _ = procedure_from_request(
                    job.kind, job.request or {}, self.service.source.rig
                )
            except Exception as err:
                with self._lock:
                    self._rig_job = None
                    self._queue_paused = f"job {job.id} could not be started: {one_line(err)}"
                self.registry.update(
                    job,
                    state="failed",
                    error=one_line(err),
                    message=f"error: {one_line(err)}",
                    finished_at=time.time(),
                )
                return
        self.registry.update(job, position=None, message="starting")
        try:
            self._submit(job, params)
        except Exception as err:
            log.error("job %s could not be started: %s", job.id, one_line(err))

    def _renumber(self) -> None:
        """Positions 1, 2, … in queue order (caller holds ``_lock``); saved in the background."""
        for position, queued in enumerate(self._queue, start=1):
            if queued.position != position:
                queued.position = position
                queued.message = f"queued (position {position})"
                self.registry.save(queued)

    # -- the queue (called from HTTP threads) -------------------------------------------------
    def queue_json(self) -> dict[str, Any]:
        """The rig's queue: paused or not (and why), the job on the rig, the waiting jobs."""
        with self._lock:
            waiting = list(self._queue)
            paused = self._queue_paused
        running = self.rig_job
        return {
            "paused": paused is not None,
            "reason": paused,
            "running": running.to_json() if running is not None else None,
            "jobs": [j.to_json() for j in waiting],
        }

    def _queued(self, job_id: str) -> Job:
        job = self.get(job_id)
        if job not in self._queue:
            raise JobConflict(f"job {job.id} is not in the queue (state {job.state})")
        return job

    def move(self, job_id: str, position: int) -> dict[str, Any]:
        """Put a queued job at ``position`` (1 = next to run)."""
        with self._lock:
            job = self._queued(job_id)
            if not 1 <= position <= len(self._queue):
                raise ValueError(
                    f"position: {position} is outside the queue; allowed 1 ≤ position ≤ "
                    f"{len(self._queue)}"
                )
            self._queue.remove(job)
            self._queue.insert(position - 1, job)
            self._renumber()
        self.registry.flush()
        return self.queue_json()

    def remove(self, job_id: str) -> dict[str, Any]:
        """Take a job out of the queue and forget it (it never ran)."""
        with self._lock:
            job = self._queued(job_id)
            self._queue.remove(job)
            self._renumber()
        self.registry.delete(job)
        return self.queue_json()

    def pause_queue(self, reason: str = "paused by the operator (API)") -> dict[str, Any]:
        """Start no further queued job (the one on the rig goes on)."""
        with self._lock:
            self._queue_paused = reason
        return self.queue_json()

    def resume_queue(self) -> dict[str, Any]:
        """Let the queue start its jobs again, the first one now if the rig is free."""
        with self._lock:
            self._queue_paused = None
        self._start_next()
        return self.queue_json()

    def _progress(self, job: Job):
        def report(p: Progress) -> None:
            changes: dict[str, Any] = {"fraction": max(0.0, min(1.0, p.fraction))}
            changes["message"] = p.message
            run_id = (p.extra or {}).get("run_id")
            if run_id and run_id not in job.run_ids:
                changes["run_ids"] = [*job.run_ids, run_id]
            if p.state == "paused":
                changes["state"] = "paused"
            elif job.state == "paused" and p.state == "running":
                changes["state"] = "running"
            self.registry.update(job, **changes)

        return report

    async def _run_procedure(self, job: Job, kind: str, params: Any) -> None:
        from daq.procedures.params import ParameterError
        from daq.procedures.sequence import run_sequence
        from daq.procedures.steps import PreconditionFailed

        session = self.service.require_session()
        job.abort = AbortSignal()
        job.confirm = asyncio.Event()
        # A lost lease on the rig stops the job wherever it waits (a run, the operator).
        unlisten = session.add_fault_listener(job.abort.set)
        if kind == "sequence":
            job.control = SequenceControl(abort=job.abort)
            if job.pause_requested:
                job.control.pause()
        report = self._progress(job)
        try:
            if job.state == "aborted":  # aborted while queued
                return
            self.registry.update(job, state="running", started_at=time.time(), message="starting")
            session.run_metadata = run_metadata(job)
            if kind == "sequence":
                assert isinstance(params, Sequence) and job.control is not None
                seq_outcome = await run_sequence(
                    session, params, control=job.control, progress=report
                )
                data = seq_outcome.to_json()
            else:
                ran = await KINDS[kind].run(session, params, abort=job.abort, progress=report)
                data = ran.to_json()
            runs = [r["run_id"] for r in data.get("runs", [])] or [data.get("run_id")]
            run_ids = list(dict.fromkeys([*job.run_ids, *[r for r in runs if r]]))
            state = "completed" if data["status"] == "completed" else "aborted"
            self.registry.update(
                job,
                state=state,
                outcome=data,
                run_ids=run_ids,
                fraction=1.0 if state == "completed" else job.fraction,
                message=f"{state}" + (f": {data['reason']}" if data.get("reason") else ""),
                error=None if state == "completed" else data.get("reason"),
            )
        except Aborted as err:
            self.registry.update(
                job, state="aborted", message=f"aborted: {err.reason}", error=err.reason
            )
        except (PreconditionFailed, RigBusy, RigLockLost, ParameterError) as err:  # the rig said no
            self.registry.update(job, state="failed", message=str(err), error=str(err))
        except StorageFault as err:  # the database refused the run: one line, no traceback
            log.error("job %s failed: %s", job.id, err)
            self.registry.update(job, state="failed", message=str(err), error=str(err))
        except Exception as err:
            log.exception("job %s failed", job.id)
            self.registry.update(
                job, state="failed", message=f"error: {one_line(err)}", error=one_line(err)
            )
        finally:
            unlisten()
            session.run_metadata = None
            with self._lock:
                if self._rig_job is job:
                    self._rig_job = None
            self.registry.update(job, finished_at=time.time(), operator_act=None)

    async def _ask_operator(self, act: OperatorAct) -> None:
        """The API's operator: show the instruction as job state, wait for confirm/abort."""
        job = self._rig_job
        if job is None or job.confirm is None or job.abort is None:
            raise Aborted(f"no job to ask the operator through: {act.instruction}")
        job.confirm.clear()
        before = job.state
        self.registry.update(
            job,
            state="waiting_for_operator",
            operator_act=dataclasses.asdict(act),
            message=act.instruction,
        )
        confirm = asyncio.ensure_future(job.confirm.wait())
        aborted = asyncio.ensure_future(job.abort.wait())
        try:
            await asyncio.wait({confirm, aborted}, return_when=asyncio.FIRST_COMPLETED)
        finally:
            confirm.cancel()
            aborted.cancel()
        self.registry.update(job, state=before, operator_act=None)
        job.abort.check()

    # -- controls (called from HTTP threads) ----------------------------------------------
    def abort(self, job_id: str, reason: str = "operator abort (API)") -> Job:
        job = self.get(job_id)
        if job.state in FINAL:
            raise JobConflict(f"job {job.id} already ended ({job.state})")
        if job.kind in ("estimation", "crosscheck"):
            raise JobConflict(f"job {job.id}: an {job.kind} cannot be aborted once started")
        with self._lock:
            queued = job in self._queue
            if queued:
                self._queue.remove(job)
                self._renumber()
        if queued or job.abort is None:  # still in the queue, or not yet on the rig loop
            self.registry.update(
                job,
                state="aborted",
                position=None,
                message=f"aborted: {reason}",
                error=reason,
                finished_at=time.time() if queued else job.finished_at,
            )
        else:
            self.service.call_soon(job.abort.set, reason)
            self.registry.update(job, message=f"aborting: {reason}")
        return job

    def pause(self, job_id: str) -> Job:
        job = self._request_pause(job_id, True)
        self.registry.update(job, message="pausing after the current step")
        return job

    def resume(self, job_id: str) -> Job:
        job = self._request_pause(job_id, False)
        self.registry.update(job, state="running" if job.state == "paused" else job.state)
        return job

    def _request_pause(self, job_id: str, paused: bool) -> Job:
        """Record that the sequence ``job_id`` should be ``paused`` (or go on) and tell its
        control on the rig loop, if it is running there yet."""
        job = self._sequence(job_id)
        job.pause_requested = paused
        if job.control is not None:
            self.service.call_soon(job.control.pause if paused else job.control.resume)
        return job

    def confirm(self, job_id: str) -> Job:
        job = self.get(job_id)
        if job.state != "waiting_for_operator" or job.confirm is None:
            raise JobConflict(f"job {job.id} is not waiting for the operator (state {job.state})")
        self.service.call_soon(job.confirm.set)
        return job

    def _sequence(self, job_id: str) -> Job:
        job = self.get(job_id)
        if job.kind != "sequence":
            raise JobConflict(f"job {job.id} is a {job.kind}; only sequences pause and resume")
        if job.state in FINAL:
            raise JobConflict(f"job {job.id} already ended ({job.state})")
        if job in self._queue:
            raise JobConflict(f"job {job.id} waits in the queue; pause the queue instead")
        return job

    def emergency_stop(self, user: str | None = None) -> builtins.list[str]:
        """Abort the procedure on the rig, pause the queue if jobs wait (they stay), put the
        rig in its safe state now, then latch the stop (naming ``user``, if known): no
        motion until an operator acknowledges it."""
        with self._lock:
            if self._queue:  # an empty queue is not held: the next start runs as before
                self._queue_paused = "emergency stop (API): resume the queue to go on"
        aborted = []
        with latching_stop(self.service, user):
            for job in list(self.jobs.values()):
                if job.kind in PROCEDURES and job.state in ACTIVE and job not in self._queue:
                    self.abort(job.id, "emergency stop (API)")
                    aborted.append(job.id)
            session = self.service.require_session()
            self.service.run(session.safe_state(), timeout_s=5.0)
        return aborted

    # -- analysis (estimation, cross-check, reports) ------------------------------------------
    def start_estimation(
        self,
        run_ids: builtins.list[str],
        method: str,
        search_effects: bool,
        user: str | None = None,
    ) -> Job:
        """Run an estimation in the analysis worker (:class:`AnalysisWorker`)."""
        return self.analysis.start_estimation(run_ids, method, search_effects, user)

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
