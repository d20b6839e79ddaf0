"""Jobs: procedures on the rig loop, estimations in a worker thread, one registry.

A procedure job (tow, spin, pendulum, thrust calibration, sequence) holds the rig for its whole
life: a second start while one is active is refused at once with the holder's name
(HTTP 409). States: ``queued → running ⇄ waiting_for_operator | paused →
completed | aborted | failed``. Every change is published to the live stream.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import logging
import shutil
import tempfile
import threading
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from api.service import RigService
from daq.operator import OperatorAct
from daq.procedures.kinds import KINDS
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal
from daq.procedures.sequence import Sequence, SequenceControl
from daq.session import Aborted, RigBusy
from daq.store.faults import one_line

log = logging.getLogger(__name__)

ACTIVE = ("queued", "running", "waiting_for_operator", "paused")
FINAL = ("completed", "aborted", "failed")
#: Jobs that hold the rig: one per run kind, and sequences of them.
PROCEDURES = (*KINDS, "sequence")
#: Ended jobs remembered (their runs and results are in the store regardless).
KEEP_ENDED = 500


class JobNotFound(KeyError):
    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "job not found"


class JobConflict(RuntimeError):
    """The request does not fit the job's state (or the rig is held by another job)."""

    def __init__(self, message: str, holder: str | None = None) -> None:
        super().__init__(message)
        self.holder = holder


@dataclass(eq=False)
class Job:
    """One job as the API shows it; mutated on the thread that runs it, under ``lock``."""

    id: str
    kind: str
    label: str
    parameters: dict[str, Any]
    state: str = "queued"
    fraction: float = 0.0
    message: str = "queued"
    run_ids: list[str] = field(default_factory=list)
    outcome: dict[str, Any] | None = None
    error: str | None = None
    result_id: int | None = None
    operator_act: dict[str, Any] | None = None
    pause_requested: bool = False
    created_at: float = field(default_factory=time.time)
    started_at: float | None = None
    finished_at: float | None = None
    #: What the operator should know about the request, e.g. a load rounded to the gram.
    notes: list[str] = field(default_factory=list)
    # rig-loop objects (procedures) — touched only through RigService.call_soon
    abort: AbortSignal | None = None
    control: SequenceControl | None = None
    confirm: asyncio.Event | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)

    def to_json(self) -> dict[str, Any]:
        with self.lock:
            return {
                "id": self.id,
                "kind": self.kind,
                "label": self.label,
                "state": self.state,
                "progress": {"fraction": self.fraction, "message": self.message},
                "parameters": self.parameters,
                "run_ids": list(self.run_ids),
                "outcome": self.outcome,
                "error": self.error,
                "result_id": self.result_id,
                "operator_act": self.operator_act,
                "created_at": self.created_at,
                "started_at": self.started_at,
                "finished_at": self.finished_at,
                "notes": list(self.notes),
            }


class JobRunner:
    """Starts, tracks and stops jobs for one ``RigService``."""

    def __init__(self, service: RigService, *, report_root: Path | None = None) -> None:
        self.service = service
        self.jobs: dict[str, Job] = {}
        self._lock = threading.Lock()
        self._rig_job: Job | None = None
        self._estimator = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="estimate")
        self._own_report_root = report_root is None
        self.report_root = report_root or Path(tempfile.mkdtemp(prefix="towrig-reports-"))
        service.operator_hook = self._ask_operator

    def close(self, *, timeout_s: float = 15.0) -> None:
        """Abort running procedures (their runs end ``aborted``, the rig safe) and wait."""
        for job in list(self.jobs.values()):
            if job.kind in PROCEDURES and job.state in ACTIVE:
                with contextlib.suppress(Exception):
                    self.abort(job.id, "service stopped")
        end = time.monotonic() + timeout_s
        while self.rig_job is not None and time.monotonic() < end:
            time.sleep(0.05)
        self._estimator.shutdown(wait=True, cancel_futures=True)
        if self._own_report_root:
            shutil.rmtree(self.report_root, ignore_errors=True)

    # -- registry ----------------------------------------------------------------------
    def get(self, job_id: str) -> Job:
        job = self.jobs.get(job_id)
        if job is None:
            raise JobNotFound(f"no job with id {job_id!r}")
        return job

    def list(self) -> list[Job]:
        return sorted(self.jobs.values(), key=lambda j: j.created_at, reverse=True)

    @property
    def rig_job(self) -> Job | None:
        """The procedure job holding the rig, if any."""
        job = self._rig_job
        return job if job is not None and job.state in ACTIVE else None

    def _new(self, kind: str, label: str, parameters: dict[str, Any]) -> Job:
        job = Job(uuid.uuid4().hex[:12], kind, label, parameters)
        self.jobs[job.id] = job
        ended = [j for j in list(self.jobs.values()) if j.state in FINAL]  # snapshot: threads
        for old in sorted(ended, key=lambda j: j.created_at)[: max(0, len(ended) - KEEP_ENDED)]:
            self.jobs.pop(old.id, None)  # runs and results stay in the store
        return job

    def _update(self, job: Job, **changes: Any) -> None:
        with job.lock:
            for name, value in changes.items():
                setattr(job, name, value)
        self.service.broadcaster.publish_job(job.to_json())

    # -- procedures ----------------------------------------------------------------------
    def start_procedure(self, kind: str, params: Any, label: str) -> Job:
        """Start a validated procedure; ``JobConflict`` (→ 409) when the rig is held."""
        session = self.service.require_session()
        parameters = params.to_json()
        with self._lock:
            busy = self.rig_job
            if busy is not None:
                raise JobConflict(
                    f"rig is busy: job {busy.id} ({busy.label}) holds the rig lock",
                    holder=f"{busy.label} (job {busy.id})",
                )
            if session.lock_holder is not None:
                raise JobConflict(
                    f"rig is busy: {session.lock_holder} holds the rig lock",
                    holder=session.lock_holder,
                )
            job = self._new(kind, label, parameters)
            note = getattr(params, "adjustment", lambda: None)()
            job.notes = [note] if note else []
            self._rig_job = job
        try:
            self.service.submit(self._run_procedure(job, kind, params))
        except Exception:
            with self._lock:
                self._rig_job = None
            job.state, job.error = "failed", "the rig service is not running"
            raise
        self.service.broadcaster.publish_job(job.to_json())
        return job

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
        from daq.procedures.motion import PreconditionFailed
        from daq.procedures.params import ParameterError
        from daq.procedures.sequence import run_sequence

        session = self.service.require_session()
        job.abort = AbortSignal()
        job.confirm = asyncio.Event()
        if kind == "sequence":
            job.control = SequenceControl(abort=job.abort)
            if job.pause_requested:
                job.control.pause()
        report = self._progress(job)
        try:
            if job.state == "aborted":  # aborted while queued
                return
            self._update(job, state="running", started_at=time.time(), message="starting")
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
        except (PreconditionFailed, RigBusy, ParameterError) as err:  # the rig said no
            self._update(job, state="failed", message=str(err), error=str(err))
        except Exception as err:
            log.exception("job %s failed", job.id)
            self._update(
                job, state="failed", message=f"error: {one_line(err)}", error=one_line(err)
            )
        finally:
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
            operator_act={"name": act.name, "instruction": act.instruction, "value": act.value},
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
        if job.abort is None:  # still queued on the rig loop
            self._update(job, state="aborted", message=f"aborted: {reason}", error=reason)
        else:
            self.service.call_soon(job.abort.set, reason)
            self._update(job, message=f"aborting: {reason}")
        return job

    def pause(self, job_id: str) -> Job:
        job = self._sequence(job_id)
        job.pause_requested = True
        if job.control is not None:
            self.service.call_soon(job.control.pause)
        self._update(job, message="pausing after the current step")
        return job

    def resume(self, job_id: str) -> Job:
        job = self._sequence(job_id)
        job.pause_requested = False
        if job.control is not None:
            self.service.call_soon(job.control.resume)
        self._update(job, state="running" if job.state == "paused" else job.state)
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
        return job

    def emergency_stop(self) -> list[str]:
        """Abort every procedure job and put the rig in its safe state now."""
        aborted = []
        for job in list(self.jobs.values()):
            if job.kind in PROCEDURES and job.state in ACTIVE:
                self.abort(job.id, "emergency stop (API)")
                aborted.append(job.id)
        session = self.service.require_session()
        self.service.run(session.safe_state(), timeout_s=5.0)
        return aborted

    # -- estimation ------------------------------------------------------------------------
    def start_estimation(self, run_ids: list[str], method: str, search_effects: bool) -> Job:
        """Run an estimation in the worker thread (never on the clock's loop)."""
        params = {"run_ids": run_ids, "method": method, "search_effects": search_effects}
        job = self._new("estimation", f"estimation {method} on {len(run_ids)} run(s)", params)
        job.run_ids = list(run_ids)
        self._estimator.submit(self._run_estimation, job, run_ids, method, search_effects)
        self.service.broadcaster.publish_job(job.to_json())
        return job

    def _run_estimation(
        self, job: Job, run_ids: list[str], method: str, search_effects: bool
    ) -> None:
        from api.estimation_job import run_estimation

        assert self.service.store is not None
        self._update(job, state="running", started_at=time.time(), message="fitting")
        report_dir = self.report_root / f"job-{job.id}"
        try:
            data = run_estimation(
                self.service.store,
                run_ids,
                method=method,
                search_effects=search_effects,
                report_dir=report_dir,
            )
            result_id = data.get("result_id")
            if result_id is not None and report_dir.exists():
                report_dir.rename(self.report_root / f"result-{result_id}")
            self._update(
                job,
                state="completed",
                fraction=1.0,
                outcome=data,
                result_id=result_id,
                message="estimation done",
            )
        except Exception as err:
            if not isinstance(err, ValueError | KeyError):
                log.exception("estimation job %s failed", job.id)
            self._update(job, state="failed", message=f"error: {err}", error=str(err))
        finally:
            self._update(job, finished_at=time.time())

    # -- cross-check ------------------------------------------------------------------------
    def start_crosscheck(
        self, weight_runs: list[str], thruster_runs: list[str], search_effects: bool = True
    ) -> Job:
        """Estimate both sets of runs and cross-check them, in the estimation worker."""
        params = {
            "weight_runs": weight_runs,
            "thruster_runs": thruster_runs,
            "search_effects": search_effects,
        }
        label = f"cross-check {len(weight_runs)} weight vs {len(thruster_runs)} thruster run(s)"
        job = self._new("crosscheck", label, params)
        job.run_ids = list(dict.fromkeys([*weight_runs, *thruster_runs]))
        self._estimator.submit(self._run_crosscheck, job, params)
        self.service.broadcaster.publish_job(job.to_json())
        return job

    def _run_crosscheck(self, job: Job, params: dict[str, Any]) -> None:
        from api.crosscheck_job import crosscheck_runs

        assert self.service.store is not None
        self._update(job, state="running", started_at=time.time(), message="fitting both sets")
        report_dir = self.report_root / f"job-{job.id}"
        try:
            data = crosscheck_runs(self.service.store, **params, report_dir=report_dir)
            self.adopt_report(data["result_id"], report_dir)
            sides = (("weight_estimation", "weight"), ("thruster_estimation", "thrusters"))
            for key, side in sides:
                self.adopt_report(data[key]["result_id"], report_dir / side)
            self._update(
                job,
                state="completed",
                fraction=1.0,
                outcome=data,
                result_id=data["result_id"],
                message=f"cross-check done: {data['verdict']}",
            )
        except Exception as err:
            if not isinstance(err, ValueError | KeyError):
                log.exception("cross-check job %s failed", job.id)
            self._update(job, state="failed", message=f"error: {err}", error=str(err))
        finally:
            self._update(job, finished_at=time.time())

    def adopt_report(self, result_id: int, folder: Path) -> None:
        """Serve ``folder``'s PNGs as the report plots of ``result_id``."""
        target = self.report_root / f"result-{result_id}"
        target.mkdir(parents=True, exist_ok=True)
        for png in folder.glob("*.png"):
            png.replace(target / png.name)

    def report_file(self, result_id: int, name: str) -> Path | None:
        """The PNG ``name`` of an estimation result's report, if this service made it."""
        folder = self.report_root / f"result-{result_id}"
        path = folder / f"{name}.png"
        if path.parent != folder or not path.is_file():
            return None
        return path
