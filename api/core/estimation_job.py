"""Estimation on stored runs (tow/spin or pendulum): load, fit, store the result with its runs.

Shared by ``rig estimate`` and the HTTP API so both give the same JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from daq.procedures.kinds import KINDS
from daq.run_data import load_run_data
from daq.store import Store
from estimation import METHODS
from estimation.pendulum.estimate import PENDULUM_METHODS


def check_estimation_request(store: Store, run_ids: Sequence[str], method: str) -> str:
    """What the runs call for — "pendulum" or "axis" (tow/spin) — with ``method`` checked.

    Raises ``ValueError`` naming the field for no runs, mixed kinds, or a method the kind
    does not have; ``RunNotFound`` for an unknown id. The API calls this before starting
    the job so such requests are a 422, not a failed job.
    """
    if not run_ids:
        raise ValueError("run_ids: give at least one run id")
    kinds = {store.get_run(rid).kind for rid in run_ids}
    estimators = {KINDS[k].estimator if k in KINDS else None for k in kinds}  # type: ignore[index]
    if "pendulum" in estimators:
        if estimators != {"pendulum"}:
            raise ValueError(
                f"run_ids: got mixed kinds {sorted(kinds)}, allowed: all pendulum runs, "
                f"or tow/spin runs only"
            )
        if method not in PENDULUM_METHODS:
            raise ValueError(
                f"method: {method!r} is not allowed for pendulum runs; allowed: "
                f"{', '.join(PENDULUM_METHODS)}"
            )
        return "pendulum"
    if method not in METHODS:
        raise ValueError(
            f"method: {method!r} is not allowed for tow/spin runs; allowed: {', '.join(METHODS)}"
        )
    return "axis"


def run_estimation(
    store: Store,
    run_ids: Sequence[str],
    *,
    method: str = "output-error",
    search_effects: bool = True,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Estimate from stored runs; returns the result JSON (with ``result_id``).

    Tow/spin runs give the axis model (``estimation.axis.estimate``); pendulum free-decay runs
    give α, β of the swing axis (``estimation.pendulum.estimate``, stored as an "estimation"
    result with ``"analysis": "pendulum"``). Raises ``ValueError`` naming the field for an
    unknown method (per kind), a run that cannot be estimated, runs of mixed kinds or
    axes; ``RunNotFound`` for an unknown id.
    """
    from estimation import estimate
    from estimation.axis.report import write_report  # matplotlib: load only when estimating

    if check_estimation_request(store, run_ids, method) == "pendulum":
        return _run_pendulum(store, run_ids, method, search_effects, report_dir)
    runs = [load_run_data(store, rid) for rid in run_ids]
    result = estimate(runs, method=method, search_effects=search_effects)
    data = result.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_report(result, runs, Path(report_dir))]
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", stored)
    return data


def _run_pendulum(
    store: Store,
    run_ids: Sequence[str],
    method: str,
    search_effects: bool,
    report_dir: str | Path | None,
) -> dict[str, Any]:
    from daq.run_data import load_pendulum_data
    from estimation.pendulum.estimate import estimate_pendulum
    from estimation.pendulum.report import write_pendulum_report

    runs = [load_pendulum_data(store, rid) for rid in run_ids]
    result = estimate_pendulum(runs, method=method, search=search_effects)
    data = result.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_pendulum_report(result, Path(report_dir))]
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", stored)
    return data
