"""Estimation on stored runs (tow/spin or pendulum): load, fit, store the result with its runs.

Shared by ``rig estimate`` and the HTTP API so both give the same JSON, and tell bad input
(``ValueError`` naming the field, found before fitting) from a fit that failed
(``EstimationFailure``) the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from api.core.estimation_failure import fit_subject, fitting
from api.core.theory_job import theory_document
from api.core.uncertainty_job import budget_document, screen_repeats
from daq.body_mass import with_body_inertia
from daq.procedures.kinds import KINDS
from daq.run_data import load_run_data
from daq.store import Store
from estimation import METHODS
from estimation.data.runs import RunData
from estimation.pendulum.data import PendulumRun
from estimation.pendulum.estimate import PENDULUM_METHODS


def check_estimation_request(store: Store, run_ids: Sequence[str], method: str) -> str:
    """What the runs call for — "pendulum" or "axis" (tow/spin) — with ``method`` checked.

    Raises ``ValueError`` naming the field for no runs, mixed kinds (a pendulum with a tow,
    a tow with a spin), or a method the kind
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
    if len(kinds) > 1:  # a tow and a spin are two axes: one fit cannot take both
        raise ValueError(
            f"run_ids: got mixed kinds {sorted(kinds)}, allowed: runs of one kind (tows of "
            f"one axis, or spins); estimate each kind on its own"
        )
    if method not in METHODS:
        raise ValueError(
            f"method: {method!r} is not allowed for tow/spin runs; allowed: {', '.join(METHODS)}"
        )
    return "axis"


def load_estimation_runs(
    store: Store, run_ids: Sequence[str], method: str
) -> tuple[str, list[RunData] | list[PendulumRun]]:
    """The runs as the estimator takes them, checked: ("axis", tow/spin runs) or
    ("pendulum", free-decay runs).

    Everything a user can get wrong is found here, before anything is fitted: raises
    ``ValueError`` naming the run and field (no applied drive, too few samples after the
    release, mixed axes, …) and ``RunNotFound`` for an unknown id. The API calls it before
    starting the job, so bad input is a 422, never a failed job."""
    from estimation.data.runs import validate_runs

    if check_estimation_request(store, run_ids, method) == "pendulum":
        from daq.run_data import load_pendulum_data
        from estimation.pendulum.estimate import validate_pendulum_runs

        swings = [load_pendulum_data(store, rid) for rid in run_ids]
        validate_pendulum_runs(swings)
        return "pendulum", swings
    # The body's own mass the tow declares: an inertia fitted below it is flagged.
    runs = [with_body_inertia(load_run_data(store, rid), store.get_run(rid)) for rid in run_ids]
    validate_runs(runs)
    return "axis", runs


def run_estimation(
    store: Store,
    run_ids: Sequence[str],
    *,
    method: str = "output-error",
    search_effects: bool = True,
    report_dir: str | Path | None = None,
    exclude_outliers: bool = False,
) -> dict[str, Any]:
    """Estimate from stored runs; returns the result JSON (with ``result_id``), with the
    uncertainty budget and the repeat analysis (``api.core.uncertainty_job``;
    ``exclude_outliers`` leaves Chauvenet-flagged repeats out of the fit).

    Tow/spin runs give the axis model (``estimation.axis.estimate``); pendulum free-decay runs
    give α, β of the swing axis (``estimation.pendulum.estimate``, stored as an "estimation"
    result with ``"analysis": "pendulum"``). Bad input raises as
    :func:`load_estimation_runs` says; a fit (or its report) that fails in its numerics
    raises ``EstimationFailure`` (``could not fit surge of run 3f2a9c1b: why``).
    """
    from api.core.rig_envelope import envelope_of_runs
    from estimation import estimate
    from estimation.axis.report import write_report  # matplotlib: load only when estimating

    what, loaded = load_estimation_runs(store, run_ids, method)
    if what == "pendulum":
        return _run_pendulum(store, loaded, method, search_effects, report_dir)  # type: ignore[arg-type]
    runs, repeats = screen_repeats(loaded, exclude_outliers)  # type: ignore[arg-type]
    subject = fit_subject(runs[0].axis, [r.run_id for r in runs])
    with fitting(subject):
        envelope = envelope_of_runs(store, [r.run_id for r in runs])  # advice within the rig
        result = estimate(runs, method=method, search_effects=search_effects, envelope=envelope)
        data = result.to_json()
    if report_dir is not None:
        with fitting(subject, "draw the report of"):
            data["report_files"] = [str(p) for p in write_report(result, runs, Path(report_dir))]
    with fitting(subject, "compute the uncertainty budget of"):
        data |= budget_document(store, runs, result, repeats, report_dir)
        data |= theory_document(store, data, repeats, report_dir)
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", stored)
    return data


def _run_pendulum(
    store: Store,
    runs: list[PendulumRun],
    method: str,
    search_effects: bool,
    report_dir: str | Path | None,
) -> dict[str, Any]:
    from estimation.pendulum.estimate import estimate_pendulum
    from estimation.pendulum.report import write_pendulum_report

    subject = fit_subject(f"{runs[0].axis} swing", [r.run_id for r in runs])
    with fitting(subject):
        result = estimate_pendulum(runs, method=method, search=search_effects)
        data = result.to_json()
    if report_dir is not None:
        with fitting(subject, "draw the report of"):
            data["report_files"] = [str(p) for p in write_pendulum_report(result, Path(report_dir))]
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", stored)
    return data
