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

One module because the runner's parts share one lock and one set of job objects; the queue and
the pipelines are short and read best next to the state they change.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import dataclasses
import logging
import shutil
import tempfile
import threading
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

from api.core.job_model import Job, JobConflict, JobNotFound, without_report_files
from api.core.job_requests import procedure_from_request
from api.core.queue_edits import QueueEdits
from api.core.rig_guard import RigGuard, latching_stop
from api.core.service import RigService
from daq.operator import OperatorAct
from daq.procedures.kinds import KINDS, RIG_KINDS
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal
from daq.procedures.sequence import Sequence, SequenceControl
from daq.rig_lock import RigLockLost
from daq.session import Aborted, RigBusy
from daq.store import Store
from daq.store.faults import StorageFault, one_line
from daq.store.jobs import JobRepository
from daq.store.schema import JOB_ACTIVE, JOB_FINAL, JobState

log = logging.getLogger(__name__)

ACTIVE = JOB_ACTIVE
FINAL = JOB_FINAL
#: Jobs that hold the rig: one per run kind, and sequences of them.
PROCEDURES = (*RIG_KINDS, "sequence")
#: Ended jobs kept in memory (all of them stay in the database).
KEEP_ENDED = 500
#: Jobs that may wait in the rig's queue: the one registry a client could otherwise grow
#: without end (a start beyond it is refused, 409).
MAX_QUEUED = 100
#: Report figures a result serves (the raster for the page, the vector beside it): media types.
REPORT_SUFFIXES = {".png": "image/png", ".svg": "image/svg+xml"}
#: Jobs ``list`` reads from the database, newest first.
LIST_LIMIT = 500
#: A progress change that is neither a new state nor a new message is written at most this often.
SAVE_EVERY_S = 1.0

__all__ = ["ACTIVE", "FINAL", "PROCEDURES", "Job", "JobConflict", "JobNotFound", "JobRunner"]


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
        self.jobs: dict[str, Job] = {}
        self._lock = threading.Lock()
        self._rig_job: Job | None = None
        self._queue: list[Job] = []
        #: Why the queue does not start its next job by itself (None: it does).
        self._queue_paused: str | None = None
        self._closing = False
        self._repo: JobRepository | None = None
        self._saved_at: dict[str, float] = {}
        self._estimator = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="estimate")
        self._writer = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="job-store")
        self._own_report_root = report_root is None
        #: Scratch space where reports are drawn before they are stored in the database.
        self.report_root = report_root or Path(tempfile.mkdtemp(prefix="towrig-reports-"))
        service.operator_hook = self._ask_operator

    # -- database ----------------------------------------------------------------------------
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
                    self.jobs[job.id] = job
                    self._queue.append(job)
            if self._queue:
                self._queue_paused = (
                    f"the service started with {len(self._queue)} job(s) queued: "
                    "resume the queue to run them"
                )
            self._renumber()

    def _save(self, job: Job, event: bool = False) -> concurrent.futures.Future:
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
        self._estimator.shutdown(wait=True, cancel_futures=True)
        self._writer.shutdown(wait=True)
        if self._own_report_root:
            shutil.rmtree(self.report_root, ignore_errors=True)

    # -- registry ----------------------------------------------------------------------
    def get(self, job_id: str) -> Job:
        job = self.jobs.get(job_id)
        if job is None:
            row = self.repo.get(job_id) if self.service.store is not None else None
            if row is None or row["rig_name"] != self.rig_name:
                raise JobNotFound(f"no job with id {job_id!r}")
            job = Job.from_row(row)
        return job

    def list(
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
        self._writer.submit(lambda: None).result(10)  # what is pending is written first
        return self.repo.events(job_id)

    @property
    def rig_job(self) -> Job | None:
        """The procedure job holding the rig, if any."""
        job = self._rig_job
        return job if job is not None and job.state in ACTIVE else None

    def _new(self, kind: str, label: str, parameters: dict[str, Any], **fields: Any) -> Job:
        job = Job(uuid.uuid4().hex[:12], kind, label, parameters, **fields)
        self.jobs[job.id] = job
        ended = [j for j in list(self.jobs.values()) if j.state in FINAL]  # snapshot: threads
        for old in sorted(ended, key=lambda j: j.created_at)[: max(0, len(ended) - KEEP_ENDED)]:
            self.jobs.pop(old.id, None)  # it stays in the database
            self._saved_at.pop(old.id, None)
        return job

    def _update(self, job: Job, **changes: Any) -> None:
        with job.lock:
            before = (job.state, job.message)
            if "state" in changes:
                changes["state"] = JobState(changes["state"])
                if changes["state"] in FINAL and job.finished_at is None:
                    # ended and its end time in one change: no reader sees one without the other
                    changes.setdefault("finished_at", time.time())
            if job.finished_at is not None:
                changes.pop("finished_at", None)  # a job ends once; its end time stays
            for name, value in changes.items():
                setattr(job, name, value)
            event = (job.state, job.message) != before
        self.service.broadcaster.publish_job(job.to_json())
        due = time.monotonic() - self._saved_at.get(job.id, 0.0) >= SAVE_EVERY_S
        if event or due or set(changes) - {"fraction", "message"}:
            self._save(job, event=event)

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
                job = self._new(kind, label, parameters, **fields)
                self._queue.append(job)
                self._renumber()
            else:
                job = self._new(kind, label, parameters, **fields)
                self._rig_job = job
        if job.position is not None:
            self._save(job, event=True).result(10)  # a queued job survives a restart at once
            self.service.broadcaster.publish_job(job.to_json())
            return job
        self._save(job, event=True)
        self._submit(job, params)
        return job

    def _submit(self, job: Job, params: Any) -> None:
        try:
            self.service.submit(self._hold_rig(job, params))
        except Exception as err:  # RigUnavailable says why (a lost rig lock, say)
            with self._lock:
                self._rig_job = None
            self._update(job, state="failed", error=one_line(err))
            raise
        self.service.broadcaster.publish_job(job.to_json())

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
                self._update(
                    job,
                    state="failed",
                    error=one_line(err),
                    message=f"error: {one_line(err)}",
                    finished_at=time.time(),
                )
                return
        self._update(job, position=None, message="starting")
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
                self._save(queued)

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
        self._writer.submit(lambda: None).result(10)
        return self.queue_json()

    def remove(self, job_id: str) -> dict[str, Any]:
        """Take a job out of the queue and forget it (it never ran)."""
        with self._lock:
            job = self._queued(job_id)
            self._queue.remove(job)
            self.jobs.pop(job.id, None)
            self._renumber()
        self._writer.submit(lambda: self.repo.delete(job.id)).result(10)
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
            self._update(job, **changes)

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
            self._update(job, state="running", started_at=time.time(), message="starting")
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
            self._update(
                job,
                state=state,
                outcome=data,
                run_ids=run_ids,
                fraction=1.0 if state == "completed" else job.fraction,
                message=f"{state}" + (f": {data['reason']}" if data.get("reason") else ""),
                error=None if state == "completed" else data.get("reason"),
            )
        except Aborted as err:
            self._update(job, state="aborted", message=f"aborted: {err.reason}", error=err.reason)
        except (PreconditionFailed, RigBusy, RigLockLost, ParameterError) as err:  # the rig said no
            self._update(job, state="failed", message=str(err), error=str(err))
        except StorageFault as err:  # the database refused the run: one line, no traceback
            log.error("job %s failed: %s", job.id, err)
            self._update(job, state="failed", message=str(err), error=str(err))
        except Exception as err:
            log.exception("job %s failed", job.id)
            self._update(
                job, state="failed", message=f"error: {one_line(err)}", error=one_line(err)
            )
        finally:
            unlisten()
            session.run_metadata = None
            with self._lock:
                if self._rig_job is job:
                    self._rig_job = None
            self._update(job, finished_at=time.time(), operator_act=None)

    async def _ask_operator(self, act: OperatorAct) -> None:
        """The API's operator: show the instruction as job state, wait for confirm/abort."""
        job = self._rig_job
        if job is None or job.confirm is None or job.abort is None:
            raise Aborted(f"no job to ask the operator through: {act.instruction}")
        job.confirm.clear()
        before = job.state
        self._update(
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
        self._update(job, state=before, operator_act=None)
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
            self._update(
                job,
                state="aborted",
                position=None,
                message=f"aborted: {reason}",
                error=reason,
                finished_at=time.time() if queued else job.finished_at,
            )
        else:
            self.service.call_soon(job.abort.set, reason)
            self._update(job, message=f"aborting: {reason}")
        return job

    def pause(self, job_id: str) -> Job:
        job = self._request_pause(job_id, True)
        self._update(job, message="pausing after the current step")
        return job

    def resume(self, job_id: str) -> Job:
        job = self._request_pause(job_id, False)
        self._update(job, state="running" if job.state == "paused" else job.state)
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

    def emergency_stop(self, user: str | None = None) -> list[str]:
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

    # -- estimation ------------------------------------------------------------------------
    def start_estimation(
        self, run_ids: list[str], method: str, search_effects: bool, user: str | None = None
    ) -> Job:
        """Run an estimation in the worker thread (never on the clock's loop), for ``user``."""
        params = {"run_ids": run_ids, "method": method, "search_effects": search_effects}
        label = f"estimation {method} on {len(run_ids)} run(s)"
        job = self._new("estimation", label, params, user_name=user)
        job.run_ids = list(run_ids)
        self._save(job, event=True)
        self._estimator.submit(self._run_estimation, job, run_ids, method, search_effects)
        self.service.broadcaster.publish_job(job.to_json())
        return job

    def _run_estimation(
        self, job: Job, run_ids: list[str], method: str, search_effects: bool
    ) -> None:
        from api.core.estimation_job import run_estimation

        def fit(store: Store, report_dir: Path) -> tuple[dict[str, Any], int | None, str]:
            data = run_estimation(
                store, run_ids, method=method, search_effects=search_effects, report_dir=report_dir
            )
            result_id = data.get("result_id")
            if result_id is not None:
                self.adopt_report(result_id, report_dir)
            return data, result_id, "estimation done"

        self._run_in_worker(job, "estimation", "fitting", fit)

    def _run_in_worker(
        self,
        job: Job,
        what: str,
        message: str,
        fit: Callable[[Store, Path], tuple[dict[str, Any], int | None, str]],
    ) -> None:
        """Run ``fit(store, report_dir)`` as ``job`` (in the estimation worker): ``running``
        with ``message``, then ``completed`` with the outcome, result id and message ``fit``
        returns, or ``failed`` with the error (logged unless it is bad input). The report
        folder goes and the finish time is stored either way."""
        assert self.service.store is not None
        self._update(job, state="running", started_at=time.time(), message=message)
        report_dir = self.report_root / f"job-{job.id}"
        try:
            data, result_id, done = fit(self.service.store, report_dir)
            data = without_report_files(data)  # scratch paths; the figures are stored
            self._update(
                job,
                state="completed",
                fraction=1.0,
                outcome=data,
                result_id=result_id,
                message=done,
            )
        except Exception as err:
            if not isinstance(err, ValueError | KeyError):
                log.exception("%s job %s failed", what, job.id)
            self._update(job, state="failed", message=f"error: {err}", error=str(err))
        finally:
            shutil.rmtree(report_dir, ignore_errors=True)
            self._update(job, finished_at=time.time())

    # -- cross-check ------------------------------------------------------------------------
    def start_crosscheck(
        self,
        weight_runs: list[str],
        thruster_runs: list[str],
        search_effects: bool = True,
        user: str | None = None,
    ) -> Job:
        """Estimate both sets of runs and cross-check them, in the estimation worker."""
        params = {
            "weight_runs": weight_runs,
            "thruster_runs": thruster_runs,
            "search_effects": search_effects,
        }
        label = f"cross-check {len(weight_runs)} weight vs {len(thruster_runs)} thruster run(s)"
        job = self._new("crosscheck", label, params, user_name=user)
        job.run_ids = list(dict.fromkeys([*weight_runs, *thruster_runs]))
        self._save(job, event=True)
        self._estimator.submit(self._run_crosscheck, job, params)
        self.service.broadcaster.publish_job(job.to_json())
        return job

    def _run_crosscheck(self, job: Job, params: dict[str, Any]) -> None:
        from api.core.crosscheck_job import crosscheck_runs

        def fit(store: Store, report_dir: Path) -> tuple[dict[str, Any], int | None, str]:
            data = crosscheck_runs(store, **params, report_dir=report_dir)
            self.adopt_report(data["result_id"], report_dir)
            sides = (("weight_estimation", "weight"), ("thruster_estimation", "thrusters"))
            for key, side in sides:
                self.adopt_report(data[key]["result_id"], report_dir / side)
            return data, data["result_id"], f"cross-check done: {data['verdict']}"

        self._run_in_worker(job, "cross-check", "fitting both sets", fit)

    # -- report files (in the database) ------------------------------------------------------
    def adopt_report(self, result_id: int, folder: Path) -> list[str]:
        """Store ``folder``'s figures (PNG for the page, SVG beside it) as the report of
        ``result_id``; the figure names."""
        files = [
            (p.name, REPORT_SUFFIXES[p.suffix], p.read_bytes())
            for suffix in REPORT_SUFFIXES
            for p in sorted(Path(folder).glob(f"*{suffix}"))
        ]
        self.repo.save_report_files(result_id, files)
        return sorted({Path(name).stem for name, _, _ in files})

    def report_names(self, result_id: int) -> list[str]:
        """Names of the report figures stored with ``result_id``."""
        return sorted({Path(name).stem for name in self.repo.report_names(result_id)})

    def report_file(
        self, result_id: int, name: str, suffix: str = ".png"
    ) -> tuple[str, bytes] | None:
        """``(media type, bytes)`` of the figure ``name`` (``.png`` or ``.svg``) of a
        result's report, if stored."""
        if suffix not in REPORT_SUFFIXES:
            return None
        return self.repo.report_file(result_id, f"{name}{suffix}")
