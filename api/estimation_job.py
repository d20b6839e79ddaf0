"""Estimation on stored runs (tow/spin or pendulum): load, fit, store the result with its runs.

Shared by ``rig estimate`` and the HTTP API so both give the same JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from daq.run_data import load_run_data
from daq.store import Store
from estimation import METHODS
from estimation.pendulum import PENDULUM_METHODS


def _kinds(store: Store, run_ids: Sequence[str]) -> dict[str, str]:
    return {rid: store.get_run(rid).kind for rid in run_ids}


def run_estimation(
    store: Store,
    run_ids: Sequence[str],
    *,
    method: str = "output-error",
    search_effects: bool = True,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Estimate from stored runs; returns the result JSON (with ``result_id``).

    Tow/spin runs give the axis model (``estimation.estimate``); pendulum free-decay runs
    give α, β of the swing axis (``estimation.pendulum``, stored as an "estimation"
    result with ``"analysis": "pendulum"``). Raises ``ValueError`` naming the field for an
    unknown method (per kind), a run that cannot be estimated, runs of mixed kinds or
    axes; ``RunNotFound`` for an unknown id.
    """
    from estimation import estimate
    from estimation.report import write_report  # matplotlib: load only when estimating

    if not run_ids:
        raise ValueError("run_ids: give at least one run id")
    kinds = _kinds(store, run_ids)
    if "pendulum" in kinds.values():
        if set(kinds.values()) != {"pendulum"}:
            raise ValueError(
                f"run_ids: got mixed kinds {sorted(set(kinds.values()))}, allowed: all "
                f"pendulum runs, or tow/spin runs only"
            )
        return _run_pendulum(store, run_ids, method, search_effects, report_dir)
    if method not in METHODS:
        raise ValueError(
            f"method: {method!r} is not allowed for tow/spin runs; allowed: {', '.join(METHODS)}"
        )
    runs = [load_run_data(store, rid) for rid in run_ids]
    result = estimate(runs, method=method, search_effects=search_effects)
    data = result.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_report(result, runs, Path(report_dir))]
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", data)
    return data


def _run_pendulum(
    store: Store,
    run_ids: Sequence[str],
    method: str,
    search_effects: bool,
    report_dir: str | Path | None,
) -> dict[str, Any]:
    from daq.run_data import load_pendulum_data
    from estimation.pendulum import estimate_pendulum
    from estimation.pendulum_report import write_pendulum_report

    if method not in PENDULUM_METHODS:
        raise ValueError(
            f"method: {method!r} is not allowed for pendulum runs; allowed: "
            f"{', '.join(PENDULUM_METHODS)}"
        )
    runs = [load_pendulum_data(store, rid) for rid in run_ids]
    result = estimate_pendulum(runs, method=method, search=search_effects)
    data = result.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_pendulum_report(result, Path(report_dir))]
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", data)
    return data
