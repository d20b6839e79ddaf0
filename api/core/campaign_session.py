"""A campaign on an open rig session (``rig campaign``, ``bench/campaign_efficiency.py``):
the same planner and trail as the service's campaign job (``api.core.campaign``), with each
chosen test run directly on the session instead of through the job queue."""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from typing import Any

from daq.axis_budget import fitted_budget
from daq.fit_exclusions import TooMuchLeftOut
from daq.procedures.recording import AbortSignal
from daq.procedures.run_kinds import KINDS
from daq.run_data import load_run_data
from daq.sample_losses import SAMPLES_LOST
from daq.session import RigSession
from estimation.design.campaign_state import Campaign
from estimation.uncertainty.budget import Budget


def fit_axis(store: Any, run_ids: list[str], campaign: Campaign) -> tuple[Any, Budget | None]:
    """The axis fit of ``run_ids`` with the campaign's envelope (advice within the rig), and
    its uncertainty budget (the campaign stops on its U)."""
    from estimation import estimate

    runs = [load_run_data(store, r) for r in run_ids]
    result = estimate(runs, n_bootstrap=0, envelope=campaign.envelope)
    return result, fitted_budget(store, runs, result)


def run_seconds(store: Any, run_id: str) -> float:
    """A run's duration on the rig: first to last sample, s."""
    t = load_run_data(store, run_id).t
    return float(t[-1] - t[0])


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
    while (decision := campaign.next()).stop is None:
        choice = decision.choice
        assert choice is not None
        test = choice.test
        raw = {test.field: test.load, "drive": test.drive}
        spec = KINDS[test.kind]  # the planner's tests are tows and spins: the kinds' entries
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
        ids = [*campaign.run_ids(test.axis), outcome.run_id]
        result, budget = await asyncio.to_thread(fit_axis, store, ids, campaign)
        seconds = await asyncio.to_thread(run_seconds, store, outcome.run_id)
        entry = campaign.recorded(choice, outcome.run_id, seconds, result, budget)
        if on_entry is not None:
            on_entry(entry)
    return campaign
