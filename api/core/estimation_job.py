"""Estimation on stored runs: load, fit, store the result with its runs.

Which fit a run takes is its kind's registry entry's estimator (``daq.estimators``: tow
and spin runs the axis model, pendulum runs the swing, free decays the single-DOF
equation); nothing here branches on the kind. Shared by ``rig estimate`` and the HTTP API
so both give the same JSON, and tell bad input (``ValueError`` naming the field, found
before fitting) from a fit that failed (``EstimationFailure``) the same way.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from api.core.estimation_failure import fit_subject, fitting
from api.core.result_subject import subject as result_subject
from api.core.rig_envelope import envelope_of_runs
from daq.estimators import Estimator
from daq.procedures.run_kinds import KINDS
from daq.store import RunInfo, Store


def stored_runs(store: Store, run_ids: Sequence[str]) -> list[RunInfo]:
    """The records of an estimate's runs (uuids or unique prefixes), in order: the one place
    an estimate reads them, each once; every later step (the estimator's load, the rig's
    envelope, the budget, the theory's rig file and water) is handed these. Raises
    ``ValueError`` naming the field for no runs, ``RunNotFound`` for an unknown id."""
    if not run_ids:
        raise ValueError("run_ids: give at least one run id")
    return [store.get_run(rid) for rid in run_ids]


def estimator_of(records: Sequence[RunInfo], method: str) -> Estimator:
    """The estimator the runs of ``records`` (:func:`stored_runs`) call for, with ``method``
    checked.

    Raises ``ValueError`` naming the field for kinds no estimator takes, mixed kinds (a
    pendulum with a tow, a tow with a spin: two axes), or a method the estimator does not
    have. The API calls this before starting the job so such requests are a 422, not a
    failed job.
    """
    kinds = sorted({run.kind for run in records})
    if len(kinds) > 1:  # a tow and a spin are two axes: one fit cannot take both
        raise ValueError(
            f"run_ids: got mixed kinds {kinds}, allowed: runs of one kind (of "
            f"{', '.join(str(k) for k, s in KINDS.items() if s.estimator)}); estimate each kind "
            "on its own"
        )
    spec = KINDS.get(kinds[0])  # type: ignore[call-overload]  # a RunKind key matches its str
    if spec is None or spec.estimator is None:
        taken = ", ".join(str(k) for k, s in KINDS.items() if s.estimator is not None)
        raise ValueError(f"run_ids: {kinds[0]} runs are not estimated; allowed: {taken}")
    estimator: Estimator = spec.estimator
    if method not in estimator.methods:
        raise ValueError(
            f"method: {method!r} is not allowed for {estimator.runs} runs; allowed: "
            f"{', '.join(estimator.methods)}"
        )
    return estimator


def load_estimation_runs(
    store: Store, records: Sequence[RunInfo], method: str
) -> tuple[str, list[Any]]:
    """The runs of ``records`` (:func:`stored_runs`) as their estimator takes them, checked:
    (estimator name, runs).

    Everything a user can get wrong is found here, before anything is fitted: raises
    ``ValueError`` naming the run and field (no applied drive, too few samples after the
    release, mixed axes, …). The API calls it before starting the job, so bad input is a
    422, never a failed job."""
    estimator = estimator_of(records, method)
    return estimator.name, estimator.load(store, records)


def run_estimation(
    store: Store,
    run_ids: Sequence[str],
    *,
    method: str = "output-error",
    search_effects: bool = True,
    report_dir: str | Path | None = None,
    exclude_outliers: bool = False,
) -> dict[str, Any]:
    """Estimate from stored runs; returns the result JSON (with ``result_id``), stored as an
    "estimation" result of the runs actually fitted; ``exclude_outliers`` leaves the repeats
    Chauvenet's criterion flags out of every estimator's fit (a tow set's in its ``screen``,
    a decay's or pendulum's in its fit); with what the estimator offers besides the fit (its
    uncertainty ``budget``, then the theory comparison, ``api.core.theory_job``).
    Bad input raises as :func:`stored_runs` and :func:`load_estimation_runs` say; a fit (or
    its report) that fails in its numerics raises ``EstimationFailure`` (``could not fit surge
    of run 3f2a9c1b: why``).
    """
    records = stored_runs(store, run_ids)  # each run read once, handed to every step below
    estimator = estimator_of(records, method)
    runs = estimator.load(store, records)
    subject = fit_subject(estimator.subject(runs), [r.run_id for r in runs])
    envelope = envelope_of_runs(store, records)  # advice within the rig
    with fitting(subject):
        result = estimator.fit(runs, method, search_effects, envelope, exclude_outliers)
        data = result.to_json()
    fitted = set(result.runs)  # a repeat the fit left out is named in its repeats, not here
    runs = [r for r in runs if r.run_id in fitted]
    records = [r for r in records if r.id in fitted]
    if estimator.budget is not None:  # before the report, which shows it
        with fitting(subject, "compute the uncertainty budget of"):
            budget = estimator.budget(records, runs, result)
            data["budget"] = None if budget is None else budget.to_json()
    if report_dir is not None and estimator.report is not None:
        with fitting(subject, "draw the report of"):
            files = estimator.report(result, runs, Path(report_dir), data.get("budget"))
            data["report_files"] = [str(p) for p in files]
    if estimator.budget is not None and estimator.compares_theory:  # reads the budget
        # the hull's theory compares a tow or spin's; here: a decay never loads the vehicle
        # file, hull theory nor the tow budget
        with fitting(subject, "compare the hull's theory with"):
            from api.core.theory_job import theory_document

            data |= theory_document(records, data, result.repeats, report_dir)
    data["subject"] = result_subject("estimation", data)  # as GET /api/results names it
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result([r.run_id for r in runs], "estimation", stored)
    return data
