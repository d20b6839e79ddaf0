"""A campaign's fit of one axis: the output-error estimate of the axis's runs with the rig's
envelope, its GUM budget (the campaign stops on U), and the planner's view of both.

It runs where analyses run (``api.core.analysis_executor``, task kind ``campaign_fit``):
in the service's analysis worker process, never in the rig's process, and hands back only
plain data (the :class:`~estimation.design.planner.AxisState`, the stored result's id and
the new run's duration), so nothing of the fit crosses the process boundary.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from api.core.estimation_job import estimator_of, load_estimation_runs, stored_runs
from daq.axis_budget import fitted_budget
from daq.store import Store
from estimation.design.planner import AxisState, state_from_result
from estimation.design.planning_envelope import Candidate, RigEnvelope

if TYPE_CHECKING:
    from estimation.uncertainty.budget import Budget


@dataclass(frozen=True)
class AxisFit:
    """What the campaign books after a run: the axis's new ``state``, the id of the stored
    result (None when not stored) and the last run's duration on the rig, s."""

    state: AxisState
    result_id: int | None
    run_s: float


def fit_campaign_axis(
    store: Store,
    run_ids: Sequence[str],
    envelope: RigEnvelope,
    recorded: Sequence[Candidate],
    store_result: bool,
) -> AxisFit:
    """Fit ``run_ids`` (one axis; the last is the run just made, ``recorded`` the tests
    behind them in order) with ``envelope`` (so the stored advice is the planner's), make
    the budget, and store the result tagged ``campaign`` when ``store_result``. A released
    axis (a pendulum) is fitted by its kind's estimator with its effect search, and its
    state carries each release's outlook (``estimation.design.release_outlook``)."""
    records = stored_runs(store, run_ids)
    released = envelope.released(recorded[-1].axis)
    if released is not None:  # a pendulum's: its estimator's fit and budget, each release's outlook
        from estimation.design.release_outlook import state_from_release

        estimator = estimator_of(records, "output-error")
        runs = estimator.load(store, records)
        result = estimator.fit(runs, "output-error", True, envelope, False)
        budget = estimator.budget(records, runs, result) if estimator.budget else None
        state = state_from_release(result, recorded, budget, released)
        result_id = _stored(store, run_ids, result, budget, store_result)
        return AxisFit(state, result_id, float(runs[-1].t[-1] - runs[-1].t[0]))
    from estimation import estimate

    _, runs = load_estimation_runs(store, records, "output-error")
    result = estimate(runs, n_bootstrap=0, envelope=envelope)
    budget = fitted_budget(records, runs, result)
    result_id = _stored(store, run_ids, result, budget, store_result)
    t = runs[-1].t
    state = state_from_result(result, recorded, budget)
    return AxisFit(state, result_id, float(t[-1] - t[0]))


def _stored(
    store: Store, run_ids: Sequence[str], result: Any, budget: Budget | None, store_result: bool
) -> int | None:
    """The id of ``result`` with its ``budget`` stored as a campaign's estimation (None when
    not ``store_result``)."""
    if not store_result:
        return None
    extra = {"campaign": True, "budget": None if budget is None else budget.to_json()}
    return store.add_result(list(run_ids), "estimation", result.to_json() | extra)
