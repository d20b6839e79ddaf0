"""The campaign job: measure, re-estimate, choose the next test, until certain or out of budget.

A campaign is a job (kind ``campaign``) in the runner's registry, run in its own thread. Each
test it chooses (``estimation.design``) is submitted like any other through
``JobRunner.start_procedure`` — validated against the rig, queued behind other jobs, held by
a paused queue or an emergency stop like them — with ``metadata.campaign`` naming the
campaign on its run. When the run is done the campaign loads the axis's runs, estimates
them with the rig's envelope (so the advice in the stored result is the planner's), stores
that result, books the run and updates its trail: the job's ``outcome`` carries the trail
(each choice, why, the uncertainty before and after) and is published on the live stream
at every step. A run that lost samples is not fitted: the same test runs again and the trail
says why (``campaign_session.repeat_if_damaged``). It ends ``completed`` at the target or the
budget (``outcome.outcome`` says which), ``aborted`` when stopped or when one of its runs did
not complete.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
import weakref
from typing import TYPE_CHECKING

from api.core.campaign_request import CampaignRequest
from api.core.job_model import Job, JobConflict
from api.core.job_requests import procedure_from_request
from api.core.rig_envelope import envelope_of
from daq.store.faults import one_line
from daq.store.schema import JOB_FINAL, JobState
from estimation.design.campaign_state import Campaign
from estimation.design.planner import Choice
from estimation.design.planning_envelope import Candidate

if TYPE_CHECKING:
    from api.core.campaign_fit import AxisFit
    from api.core.jobs import JobRunner

log = logging.getLogger(__name__)
#: How often a campaign whose job is queued looks whether it was stopped meanwhile (s); the
#: job's end wakes it at once.
POLL_S = 0.2


def instructions(test: Candidate, g: float, drum_radius_m: float | None) -> str:
    """What the operator does for ``test`` (the procedure asks for each act as well)."""
    if test.release is not None:
        return f"{test.describe()}: pull it out to {test.load:.4g} {test.release.unit} and latch it"
    if test.drive == "thrusters":
        return f"{test.describe()}: thrusters mounted, no weight hung"
    load = abs(test.load)
    kg = load / g if test.axis == "surge" else load / g / (drum_radius_m or 1.0)
    where = (
        ("on the far-end pulley, carriage at the far end" if test.load < 0 else "on the tow line")
        if test.axis == "surge"
        else ("on the drum cord wound the other way" if test.load < 0 else "on the drum cord")
    )
    return f"{test.describe()}: hang {kg:.3f} kg {where}"


#: Each job runner's campaigns, kept as long as the runner lives.
_RUNNERS: weakref.WeakKeyDictionary[JobRunner, CampaignRunner] = weakref.WeakKeyDictionary()
_RUNNERS_LOCK = threading.Lock()


class CampaignRunner:
    """The campaigns of one ``JobRunner`` (one per runner: :meth:`of`)."""

    def __init__(self, runner: JobRunner) -> None:
        self.runner = runner
        self._stops: dict[str, threading.Event] = {}
        self._threads: dict[str, threading.Thread] = {}
        #: Set when the service stops: campaigns end "aborted: the service stopped".
        self._closing = False
        runner.before_close.append(self.close)

    @classmethod
    def of(cls, runner: JobRunner) -> CampaignRunner:
        """The one ``CampaignRunner`` of ``runner`` (made on first use)."""
        with _RUNNERS_LOCK:
            existing = _RUNNERS.get(runner)
            if existing is None:
                existing = _RUNNERS[runner] = cls(runner)
        return existing

    def start(self, request: CampaignRequest, user: str | None = None) -> Job:
        """Start the campaign ``request`` asks for, for ``user``; ``ValueError`` naming the
        field when the rig cannot test an axis asked for; the refusal of a start (an
        unacknowledged emergency stop, a hold by someone else) at once, as for any test."""
        from api.core.rig_guard import RigGuard

        service = self.runner.service
        RigGuard.of(service).check_start(user)
        store = service.store
        envelope = envelope_of(service.source.rig, store)
        target = request.target(envelope)
        campaign = Campaign(target, envelope)  # ValueError: axes the rig cannot test
        label = (
            f"campaign to U ≤ {target.relative * 100:g} % on {' + '.join(target.axes)} "
            f"(≤ {target.max_runs} runs, ≤ {target.max_minutes:g} tank min)"
        )
        params = {
            "target_percent": target.relative * 100,
            "axes": list(target.axes),
            "max_runs": target.max_runs,
            "max_minutes": target.max_minutes,
        }
        job = self.runner.registry.new("campaign", label, params, user_name=user)
        job.outcome = campaign.to_json()
        self.runner.registry.save(job, event=True)
        stop = self._stops[job.id] = threading.Event()
        thread = self._threads[job.id] = threading.Thread(
            target=self._run, args=(job, campaign, stop), name=f"campaign-{job.id}", daemon=True
        )
        thread.start()
        return job

    def stop(self, job_id: str) -> Job:
        """No further test: a test it queued that has not started leaves the queue; one on the
        rig goes on (abort it like any job) and the campaign ends when it does."""
        job = self.runner.get(job_id)
        if job.kind != "campaign":
            raise JobConflict(f"job {job_id} is a {job.kind} job, not a campaign")
        event = self._stops.get(job_id)
        if event is None or job.state in JOB_FINAL:
            raise JobConflict(f"campaign {job_id} has ended ({job.state})")
        event.set()
        return job

    def close(self, timeout_s: float = 30.0) -> None:
        """The service stops (after its jobs on the rig were aborted): every campaign ends
        with that reason, and its thread has written its ending before the registry closes
        (a fit running finishes first, up to ``timeout_s``)."""
        self._closing = True
        for event in list(self._stops.values()):
            event.set()
        deadline = time.monotonic() + timeout_s
        for job_id, thread in list(self._threads.items()):
            thread.join(max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                log.warning("campaign %s ran %.0f s past the service stop", job_id, timeout_s)

    def _stopped_why(self) -> str:
        return "the service stopped" if self._closing else "stopped by the operator"

    # -- the loop (its own thread) ---------------------------------------------------------
    def _run(self, job: Job, campaign: Campaign, stop: threading.Event) -> None:
        runner = self.runner
        runner.registry.update(job, state="running", started_at=time.time(), message="planning")
        try:
            state, message = self._loop(job, campaign, stop)
            runner.registry.update(job, state=state, outcome=campaign.to_json(), message=message)
        except Exception as err:  # ours, not the user's: said, and the rig untouched
            log.exception("campaign %s failed", job.id)
            campaign.outcome = f"failed: {one_line(err)}"
            runner.registry.update(
                job,
                state="failed",
                outcome=campaign.to_json(),
                error=one_line(err),
                message=f"error: {one_line(err)}",
            )
        finally:
            self._stops.pop(job.id, None)
            self._threads.pop(job.id, None)

    def _loop(self, job: Job, campaign: Campaign, stop: threading.Event) -> tuple[str, str]:
        runner, service = self.runner, self.runner.service
        rig = service.source.rig
        while True:
            if stop.is_set():
                campaign.outcome = self._stopped_why()
                return "aborted", campaign.outcome
            decision = campaign.next()
            if decision.stop is not None:
                return "completed", f"done: {decision.stop}"
            choice = decision.choice
            assert choice is not None
            test = choice.test
            request = test.request() | {"metadata": {"campaign": job.id}}
            params, label = procedure_from_request(test.kind, request, rig, service.store)
            what = instructions(test, rig.rig.g, rig.geometry.spin_drum_radius_m)
            campaign.pending = {"test": test.describe(), "why": choice.why, "instructions": what}
            try:
                item = runner.start_procedure(
                    test.kind, params, label, request=request, user=job.user_name
                )
            except JobConflict as err:  # an unacknowledged e-stop, a hold, a full queue
                campaign.outcome = f"refused: {err}"
                return "aborted", f"its next test was refused: {err}"
            campaign.pending["job_id"] = item.id
            runner.registry.update(
                job,
                outcome=campaign.to_json(),
                message=f"run {campaign.runs_used + 1}: {what} (job {item.id})",
                fraction=min(0.99, campaign.runs_used / campaign.target.max_runs),
            )
            ended = self._wait(item, stop)
            if ended is None:  # its queued test never ran: out of the queue with it
                with contextlib.suppress(JobConflict):
                    runner.remove(item.id)
                campaign.outcome = self._stopped_why()
                return "aborted", f"{campaign.outcome} while job {item.id} waited"
            if ended.run_ids:
                from api.core.campaign_session import repeat_if_damaged  # loads the estimators

                damaged, repeated = repeat_if_damaged(
                    service.store, campaign, choice, ended.run_ids[-1]
                )
                if damaged:  # samples lost: the test runs again, this run is not fitted
                    if repeated is None:
                        return "aborted", f"{campaign.outcome}: campaign stopped"
                    repeated |= {"instructions": what, "job_id": item.id}
                    runner.registry.update(job, outcome=campaign.to_json())
                    continue
            if ended.state != JobState.COMPLETED or not ended.run_ids:
                campaign.outcome = f"job {item.id} ended {ended.state}"
                return "aborted", f"job {item.id} ({label}) ended {ended.state}: campaign stopped"
            run_id = ended.run_ids[-1]
            fitting = f"estimating {test.axis} with run {run_id} and its uncertainty budget"
            campaign.pending = {"test": test.describe(), "why": "the planner needs the new fit",
                                "instructions": fitting, "job_id": item.id}  # fmt: skip
            runner.registry.update(job, outcome=campaign.to_json(), message=fitting)
            fit = self._fit(campaign, choice, run_id)
            campaign.pending = None
            entry = campaign.recorded(choice, run_id, fit.run_s, fit.state)
            entry["instructions"] = what
            entry["job_id"] = item.id
            runner.registry.update(job, outcome=campaign.to_json(), run_ids=[*job.run_ids, run_id])

    def _wait(self, item: Job, stop: threading.Event) -> Job | None:
        """``item`` once it ended; None when the campaign is stopped while it is queued."""
        while item.state not in JOB_FINAL:
            # Woken as the job ends (it was polled: up to POLL_S late for each test); a stop
            # takes a queued job out, but a running one is waited for (not spun on).
            item.ended.wait(POLL_S)
            if stop.is_set() and item.position is not None:
                return None
        return item

    def _fit(self, campaign: Campaign, choice: Choice, run_id: str) -> AxisFit:
        """The axis's fit on its runs and ``run_id`` with its uncertainty budget, stored as a
        result: in the analysis worker process, never in the rig's (``campaign_fit``)."""
        from api.core.campaign_session import campaign_fit_task, fit_outcome

        store = self.runner.service.store
        assert store is not None
        task = campaign_fit_task(store, campaign, choice, run_id, store_result=True)
        return fit_outcome(self.runner.analysis.executor_for(store).run(task))
