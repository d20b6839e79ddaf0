"""The rig worker: procedure jobs (tow, spin, pendulum, thrust calibration, sequence) run on
the rig's loop, one at a time, taken from :class:`api.core.job_queue.RigQueue`; the operator
bridge (an operator act is shown as the job's state until confirmed or aborted); the controls
of a running job (abort, pause, resume, confirm) and the emergency stop.

A procedure job's states: ``queued → running ⇄ waiting_for_operator | paused → completed |
aborted | failed``. Its rig-loop objects (abort signal, confirm event, sequence control) are
made and touched on the rig loop only; other threads reach them through
``RigService.call_soon``.
"""

from __future__ import annotations

import asyncio
import dataclasses
import logging
import time
from collections.abc import Callable
from typing import Any

from api.core.job_model import Job, JobConflict
from api.core.job_queue import RigQueue
from api.core.job_registry import JobRegistry
from api.core.job_requests import procedure_from_request
from api.core.rig_guard import RigGuard, latching_stop
from api.core.service import RigService
from daq.operator import OperatorAct
from daq.procedures.params import Progress
from daq.procedures.recording import AbortSignal
from daq.procedures.run_kinds import KINDS, RIG_KINDS
from daq.procedures.sequence import Sequence, SequenceControl
from daq.rig_lock import RigLockLost
from daq.session import Aborted, RigBusy
from daq.store.faults import StorageFault, one_line
from daq.store.free_space import check_room
from daq.store.schema import JOB_ACTIVE, JOB_FINAL, JobState
from daq.vocabulary import RunStatus

log = logging.getLogger(__name__)

#: Jobs that hold the rig: one per run kind, and sequences of them.
PROCEDURES = (*RIG_KINDS, "sequence")


def run_metadata(job: Job) -> dict[str, Any]:
    """The metadata a procedure job puts on its runs: its request's, then who started it
    and the job (``started_by``, ``job_id``; a sequence adds itself and the step)."""
    from daq.store.run_metadata import check_run_metadata

    meta = check_run_metadata((job.request or {}).get("metadata"))
    return meta | {"job_id": job.id} | ({"started_by": job.user_name} if job.user_name else {})


class RigWorker:
    """Runs the procedure jobs of ``registry`` on ``service``'s rig loop, in queue order."""

    def __init__(self, service: RigService, registry: JobRegistry) -> None:
        self.service = service
        self.registry = registry
        self.queue = RigQueue(
            registry,
            start=self._start_queued,
            refusal=lambda job: RigGuard.of(service).refusal(job.user_name),
        )
        service.operator_hook = self._ask_operator

    def on_rig(self) -> list[Job]:
        """Procedure jobs that have not ended and do not wait in the queue."""
        return [
            job
            for job in list(self.registry.jobs.values())
            if job.kind in PROCEDURES and job.state in JOB_ACTIVE and job not in self.queue
        ]

    # -- starting ------------------------------------------------------------------------------
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
        else holds the rig (``api.core.rig_guard``), while the rig's state refuses the kind
        (its ``KindSpec.refusal``: → 409), and while the disk a run would be stored on is
        full (``StorageFull``, → 503)."""
        from daq.store.run_metadata import check_run_metadata

        check_run_metadata((request or {}).get("metadata"))
        session = self.service.require_session()
        RigGuard.of(self.service).check_start(user)
        spec = RIG_KINDS.get(kind)
        if spec is not None and spec.refusal is not None and (why := spec.refusal(session)):
            raise JobConflict(why)  # the rig's state (thrusters not armed), not a parameter
        if self.service.store is not None:  # a full disk refuses the start (503), not the run
            check_room(self.service.store)
        parameters = params.to_json()
        note = getattr(params, "adjustment", lambda: None)()
        fields = {"notes": [note] if note else [], "request": request, "params": params}
        fields["user_name"] = user
        job = self.queue.admit(
            lambda: self.registry.new(kind, label, parameters, **fields),
            queue=queue,
            lock_holder=session.lock_holder,
        )
        if job.position is not None:
            # a queued job survives a restart at once
            self.registry.save(job, event=True).result(10)
            self.registry.publish(job)
            return job
        self.registry.save(job, event=True)
        self._submit(job, params)
        return job

    def _start_queued(self, job: Job) -> None:
        """Run ``job``, which the queue just put on the rig (its parameters rebuilt from its
        request if it was queued before a restart; if that fails the queue pauses)."""
        params = job.params
        if params is None:  # queued before a restart: rebuilt as the route built it
            try:
                params, _ = procedure_from_request(
                    job.kind, job.request or {}, self.service.source.rig
                )
            except Exception as err:
                self.queue.vacate(job, pause=f"job {job.id} could not be started: {one_line(err)}")
                self.registry.update(
                    job,
                    state=JobState.FAILED,
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

    def _submit(self, job: Job, params: Any) -> None:
        try:
            self.service.submit(self._hold_rig(job, params))
        except Exception as err:  # RigUnavailable says why (a lost rig lock, say)
            self.queue.vacate(job)
            self.registry.update(job, state=JobState.FAILED, error=one_line(err))
            raise
        self.registry.publish(job)

    async def _hold_rig(self, job: Job, params: Any) -> None:
        """Run a procedure, then hand the rig to the next queued job."""
        try:
            await self._run_procedure(job, params)
        finally:
            self.queue.rig_freed(job)

    # -- running (on the rig loop) -------------------------------------------------------------
    def _progress(self, job: Job) -> Callable[[Progress], None]:
        def report(p: Progress) -> None:
            changes: dict[str, Any] = {"fraction": max(0.0, min(1.0, p.fraction))}
            changes["message"] = p.message
            run_id = (p.extra or {}).get("run_id")
            if run_id and run_id not in job.run_ids:
                changes["run_ids"] = [*job.run_ids, run_id]
            if p.state == JobState.PAUSED:
                changes["state"] = JobState.PAUSED
            elif job.state == JobState.PAUSED and p.state == JobState.RUNNING:
                changes["state"] = JobState.RUNNING
            self.registry.update(job, **changes)

        return report

    async def _run_procedure(self, job: Job, params: Any) -> None:
        from daq.procedures.axis_steps import PreconditionFailed
        from daq.procedures.params import ParameterError
        from daq.procedures.sequence import run_sequence

        update = self.registry.update
        session = self.service.require_session()
        job.abort = AbortSignal()
        job.confirm = asyncio.Event()
        # A lost lease on the rig stops the job wherever it waits (a run, the operator).
        unlisten = session.add_fault_listener(job.abort.set)
        if job.kind == "sequence":
            job.control = SequenceControl(abort=job.abort)
            if job.pause_requested:
                job.control.pause()
        report = self._progress(job)
        try:
            if job.state == JobState.ABORTED:  # aborted while queued
                return
            update(job, state=JobState.RUNNING, started_at=time.time(), message="starting")
            session.run_metadata = run_metadata(job)
            if job.kind == "sequence":
                assert isinstance(params, Sequence) and job.control is not None
                seq_outcome = await run_sequence(
                    session, params, control=job.control, progress=report
                )
                data = seq_outcome.to_json()
            else:
                ran = await KINDS[job.kind].run(session, params, abort=job.abort, progress=report)
                data = ran.to_json()
            runs = [r["run_id"] for r in data.get("runs", [])] or [data.get("run_id")]
            run_ids = list(dict.fromkeys([*job.run_ids, *[r for r in runs if r]]))
            done = data["status"] == RunStatus.COMPLETED
            state = JobState.COMPLETED if done else JobState.ABORTED
            update(
                job,
                state=state,
                outcome=data,
                run_ids=run_ids,
                fraction=1.0 if done else job.fraction,
                message=f"{state}" + (f": {data['reason']}" if data.get("reason") else ""),
                error=None if done else data.get("reason"),
            )
        except Aborted as err:
            update(job, state=JobState.ABORTED, message=f"aborted: {err.reason}", error=err.reason)
        except (PreconditionFailed, RigBusy, RigLockLost, ParameterError) as err:  # the rig said no
            update(job, state=JobState.FAILED, message=str(err), error=str(err))
        except StorageFault as err:  # the database refused the run: one line, no traceback
            log.error("job %s failed: %s", job.id, err)
            update(job, state=JobState.FAILED, message=str(err), error=str(err))
        except Exception as err:
            log.exception("job %s failed", job.id)
            update(
                job,
                state=JobState.FAILED,
                message=f"error: {one_line(err)}",
                error=one_line(err),
            )
        finally:
            unlisten()
            session.run_metadata = None
            self.queue.vacate(job)
            update(job, finished_at=time.time(), operator_act=None)

    async def _ask_operator(self, act: OperatorAct) -> None:
        """The API's operator: show the instruction as job state, wait for confirm/abort."""
        job = self.queue.holder
        if job is None or job.confirm is None or job.abort is None:
            raise Aborted(f"no job to ask the operator through: {act.instruction}")
        job.confirm.clear()
        before = job.state
        self.registry.update(
            job,
            state=JobState.WAITING_FOR_OPERATOR,
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

    # -- controls (called from HTTP threads) ---------------------------------------------------
    def abort(self, job_id: str, reason: str = "operator abort (API)") -> Job:
        """Abort a procedure job: one waiting in the queue leaves it ``aborted``; one on the
        rig is told to stop (its run ends ``aborted``, the rig safe)."""
        job = self.registry.get(job_id)
        if job.state in JOB_FINAL:
            raise JobConflict(f"job {job.id} already ended ({job.state})")
        queued = self.queue.discard(job)
        if queued or job.abort is None:  # still in the queue, or not yet on the rig loop
            self.registry.update(
                job,
                state=JobState.ABORTED,
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
        """Pause a sequence after the step in progress."""
        job = self._request_pause(job_id, True)
        self.registry.update(job, message="pausing after the current step")
        return job

    def resume(self, job_id: str) -> Job:
        """Resume a paused sequence."""
        job = self._request_pause(job_id, False)
        paused = job.state == JobState.PAUSED
        self.registry.update(job, state=JobState.RUNNING if paused else job.state)
        return job

    def _request_pause(self, job_id: str, paused: bool) -> Job:
        """Record that the sequence ``job_id`` should be ``paused`` (or go on) and tell its
        control on the rig loop, if it is running there yet."""
        job = self.registry.get(job_id)
        if job.kind != "sequence":
            raise JobConflict(f"job {job.id} is a {job.kind}; only sequences pause and resume")
        if job.state in JOB_FINAL:
            raise JobConflict(f"job {job.id} already ended ({job.state})")
        if job in self.queue:
            raise JobConflict(f"job {job.id} waits in the queue; pause the queue instead")
        job.pause_requested = paused
        if job.control is not None:
            self.service.call_soon(job.control.pause if paused else job.control.resume)
        return job

    def confirm(self, job_id: str) -> Job:
        """Tell a job waiting for the operator that the operator did what it asked."""
        job = self.registry.get(job_id)
        if job.state != JobState.WAITING_FOR_OPERATOR or job.confirm is None:
            raise JobConflict(f"job {job.id} is not waiting for the operator (state {job.state})")
        self.service.call_soon(job.confirm.set)
        return job

    def emergency_stop(self, user: str | None = None) -> list[str]:
        """Abort the procedure on the rig, pause the queue if jobs wait (they stay), put the
        rig in its safe state now, then latch the stop (naming ``user``, if known): no
        motion until an operator acknowledges it."""
        self.queue.pause_if_waiting("emergency stop (API): resume the queue to go on")
        aborted = []
        with latching_stop(self.service, user):
            for job in self.on_rig():
                self.abort(job.id, "emergency stop (API)")
                aborted.append(job.id)
            session = self.service.require_session()
            self.service.run(session.safe_state(), timeout_s=5.0)
        return aborted
