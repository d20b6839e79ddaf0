"""Estimation on stored runs: load, fit, store the result with its runs.

Shared by ``rig estimate`` and the HTTP API so both give the same JSON.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from daq.run_data import load_run_data
from daq.store import Store
from estimation import METHODS


def run_estimation(
    store: Store,
    run_ids: Sequence[str],
    *,
    method: str = "output-error",
    search_effects: bool = True,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Estimate the axis model from stored runs; returns the result JSON (with ``result_id``).

    Raises ``ValueError`` naming the field for an unknown method, a run that cannot be
    estimated or runs of mixed axes; ``RunNotFound`` for an unknown id.
    """
    from estimation import estimate
    from estimation.report import write_report  # matplotlib: load only when estimating

    if method not in METHODS:
        raise ValueError(f"method: {method!r} is not allowed; allowed: {', '.join(METHODS)}")
    if not run_ids:
        raise ValueError("run_ids: give at least one run id")
    runs = [load_run_data(store, rid) for rid in run_ids]
    result = estimate(runs, method=method, search_effects=search_effects)
    data = result.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_report(result, runs, Path(report_dir))]
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", data)
    return data
