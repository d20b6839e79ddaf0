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

from api.core.estimation_job import load_estimation_runs, stored_runs
from daq.axis_budget import fitted_budget
from daq.store import Store
from estimation.design.planner import AxisState, state_from_result
from estimation.design.planning_envelope import Candidate, RigEnvelope


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
    the budget, and store the result tagged ``campaign`` when ``store_result``."""
    from estimation import estimate

    records = stored_runs(store, run_ids)
    _, runs = load_estimation_runs(store, records, "output-error")
    result = estimate(runs, n_bootstrap=0, envelope=envelope)
    budget = fitted_budget(records, runs, result)
    result_id = None
    if store_result:
        extra = {"campaign": True, "budget": None if budget is None else budget.to_json()}
        result_id = store.add_result(list(run_ids), "estimation", result.to_json() | extra)
    t = runs[-1].t
    state = state_from_result(result, recorded, budget)
    return AxisFit(state, result_id, float(t[-1] - t[0]))
