"""A campaign on an open rig session (``rig campaign``, ``bench/campaign_efficiency.py``):
the same planner and trail as the service's campaign job (``api.core.campaign``), with each
chosen test run directly on the session instead of through the job queue."""

from __future__ import annotations

import asyncio
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from api.core.analysis_executor import AnalysisOutcome, AnalysisTask, ProcessExecutor, executor_for
from api.core.campaign_fit import AxisFit
from daq.fit_exclusions import TooMuchLeftOut
from daq.procedures.recording import AbortSignal
from daq.procedures.run_kinds import KINDS
from daq.run_data import load_run_data
from daq.sample_losses import SAMPLES_LOST
from daq.session import RigSession
from daq.vocabulary import AXES
from estimation.design.campaign_state import Campaign
from estimation.design.planner import Choice


class CampaignFitFailed(RuntimeError):
    """A campaign's fit of an axis failed (the analysis outcome's one line)."""


def campaign_fit_task(
    store: Any, campaign: Campaign, choice: Choice, run_id: str, *, store_result: bool
) -> AnalysisTask:
    """The analysis task that fits ``choice``'s axis with its runs and ``run_id``."""
    params = {
        "run_ids": [*campaign.run_ids(choice.test.axis), run_id],
        "envelope": campaign.envelope,
        "recorded": campaign.tests_after(choice),
        "store_result": store_result,
    }
    return AnalysisTask("campaign_fit", params, store.url, Path(tempfile.gettempdir()))


def fit_outcome(outcome: AnalysisOutcome) -> AxisFit:
    """The ``AxisFit`` of a campaign fit's outcome; ``CampaignFitFailed`` with its error."""
    if outcome.error is not None or outcome.data is None:
        raise CampaignFitFailed(outcome.error or "the fit returned nothing")
    fit: AxisFit = outcome.data["fit"]
    return fit


def damage_of(store: Any, run_id: str) -> str | None:
    """Why a run is repeated rather than fitted (None: fit it): it was aborted for lost
    samples, or what it lost leaves too little to fit (``daq.fit_exclusions``: a hole longer
    than its kind tolerates, or over a fifth of its free motion). A run whose holes are
    within that is fitted without them (the result says what was left out): on a busy PC
    one missed slot in a tow is common, and repeating every such run never ended a campaign
    (three repeats in a row for single slots missed under CI's load)."""
    run = store.get_run(run_id)
    if run.status != "completed":
        return run.reason if run.reason and SAMPLES_LOST in run.reason else None
    if AXES[run.kind].drive_key is None:  # a release (pendulum): its loader has no window
        return None  # report to judge; a hole beyond its tolerance aborted the run above
    try:
        load_run_data(store, run_id).window_report()
    except TooMuchLeftOut as err:
        return str(err)
    return None


def repeat_if_damaged(
    store: Any, campaign: Campaign, choice: Any, run_id: str
) -> tuple[bool, dict | None]:
    """(damaged, its trail entry): a damaged run is booked as a repeat (``Campaign.repeat``;
    the entry is None when the campaign gives up, ``outcome`` says why); a run fine to fit
    is (False, None), nothing booked."""
    damage = damage_of(store, run_id)
    if damage is None:
        return False, None
    seconds = store.get_run(run_id).duration_s or 0.0
    return True, campaign.repeat(choice, run_id, seconds, damage)


async def run_campaign(
    session: RigSession,
    campaign: Campaign,
    *,
    abort: AbortSignal | None = None,
    on_entry: Callable[[dict[str, Any]], None] | None = None,
    tag: str | None = None,
) -> Campaign:
    """Run ``campaign`` to its target or budget on ``session``; ``on_entry`` gets each trail
    entry as it is booked; ``tag`` goes on each run as ``metadata.campaign``. A run that lost
    samples is repeated (``repeat_if_damaged``); another run that does not complete ends
    the campaign (``outcome``)."""
    store = session.store
    abort = abort or AbortSignal()
    # The fits run where analyses run: a worker process at lower priority for a database
    # other processes can open, never beside the clock in this process (in-memory aside).
    executor = executor_for(store)
    if isinstance(executor, ProcessExecutor):
        executor.start()  # its imports overlap the first run
    while (decision := campaign.next()).stop is None:
        choice = decision.choice
        assert choice is not None
        test = choice.test
        raw = test.request()  # as the service's campaign sends it and the trail records it
        spec = KINDS[test.kind]  # the planner's tests: the kinds' entries
        if tag is not None:
            session.run_metadata = (session.run_metadata or {}) | {"campaign": tag}
        ran = await spec.run(
            session, spec.check(raw, session.rig), abort=abort, progress=lambda _: None
        )
        outcome = ran.run
        damaged, repeated = await asyncio.to_thread(
            repeat_if_damaged, store, campaign, choice, outcome.run_id
        )
        if damaged:  # samples lost: the test runs again, this run is not fitted
            if repeated is None:  # damaged too often: the campaign stops (outcome)
                return campaign
            if on_entry is not None:
                on_entry(repeated)
            continue
        if outcome.status != "completed":
            campaign.outcome = f"{test.command}: {outcome.status} ({outcome.reason})"
            return campaign
        task = campaign_fit_task(store, campaign, choice, outcome.run_id, store_result=False)
        fit = fit_outcome(await asyncio.to_thread(executor.run, task))
        entry = campaign.recorded(choice, outcome.run_id, fit.run_s, fit.state)
        if on_entry is not None:
            on_entry(entry)
    return campaign
