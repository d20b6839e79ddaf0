"""The analysis worker: estimations and cross-checks as jobs, one at a time, in one worker
thread (never on the rig's loop, never on an HTTP thread), and the report figures they draw,
stored in the database with their result.

A job here needs no rig: it starts ``running`` at once, ends ``completed`` with its outcome
and result id or ``failed`` with the error, and cannot be aborted once started.
"""

from __future__ import annotations

import concurrent.futures
import logging
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from api.core.job_model import Job, without_report_files
from api.core.job_registry import JobRegistry
from daq.store import Store
from daq.store.schema import JobState

log = logging.getLogger(__name__)

#: Report figures a result serves (the raster for the page, the vector beside it): media types.
REPORT_SUFFIXES = {".png": "image/png", ".svg": "image/svg+xml"}
#: The report's text, stored beside its figures so the report can be downloaded later.
REPORT_TEXT = ("report.md", "text/markdown; charset=utf-8")
#: Job kinds this worker runs.
ANALYSES = ("estimation", "crosscheck")

#: ``fit(store, report_dir)`` → (outcome, result id, closing message).
Fit = Callable[[Store, Path], tuple[dict[str, Any], int | None, str]]


class AnalysisWorker:
    """Runs estimation and cross-check jobs of ``registry`` in its thread; drawn reports go
    to ``report_root`` first, then into the database."""

    def __init__(self, registry: JobRegistry, report_root: Path) -> None:
        self.registry = registry
        self.report_root = report_root
        self._pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="estimate")

    def close(self) -> None:
        """Drop the jobs not started, wait for the one running."""
        self._pool.shutdown(wait=True, cancel_futures=True)

    # -- estimation ------------------------------------------------------------------------
    def start_estimation(
        self,
        run_ids: list[str],
        method: str,
        search_effects: bool,
        user: str | None = None,
        exclude_outliers: bool = False,
    ) -> Job:
        """Run an estimation in the worker thread (never on the clock's loop), for ``user``;
        ``exclude_outliers`` leaves Chauvenet-flagged repeats out of the fit."""
        params = {
            "run_ids": run_ids,
            "method": method,
            "search_effects": search_effects,
            "exclude_outliers": exclude_outliers,
        }
        label = f"estimation {method} on {len(run_ids)} run(s)"
        job = self.registry.new("estimation", label, params, user_name=user)
        job.run_ids = list(run_ids)
        self._start(
            job, self._run_estimation, job, run_ids, method, search_effects, exclude_outliers
        )
        return job

    def _run_estimation(
        self,
        job: Job,
        run_ids: list[str],
        method: str,
        search_effects: bool,
        exclude_outliers: bool = False,
    ) -> None:
        from api.core.estimation_job import run_estimation

        def fit(store: Store, report_dir: Path) -> tuple[dict[str, Any], int | None, str]:
            data = run_estimation(
                store,
                run_ids,
                method=method,
                search_effects=search_effects,
                report_dir=report_dir,
                exclude_outliers=exclude_outliers,
            )
            result_id = data.get("result_id")
            if result_id is not None:
                self.adopt_report(result_id, report_dir)
            return data, result_id, "estimation done"

        self._run(job, "estimation", "fitting", fit)

    # -- cross-check -------------------------------------------------------------------------
    def start_crosscheck(
        self,
        weight_runs: list[str],
        thruster_runs: list[str],
        search_effects: bool = True,
        user: str | None = None,
    ) -> Job:
        """Estimate both sets of runs and cross-check them, in the worker thread."""
        params = {
            "weight_runs": weight_runs,
            "thruster_runs": thruster_runs,
            "search_effects": search_effects,
        }
        label = f"cross-check {len(weight_runs)} weight vs {len(thruster_runs)} thruster run(s)"
        job = self.registry.new("crosscheck", label, params, user_name=user)
        job.run_ids = list(dict.fromkeys([*weight_runs, *thruster_runs]))
        self._start(job, self._run_crosscheck, job, params)
        return job

    def _run_crosscheck(self, job: Job, params: dict[str, Any]) -> None:
        from api.core.crosscheck_job import crosscheck_runs

        def fit(store: Store, report_dir: Path) -> tuple[dict[str, Any], int | None, str]:
            data = crosscheck_runs(store, **params, report_dir=report_dir)
            self.adopt_report(data["result_id"], report_dir)
            sides = (("weight_estimation", "weight"), ("thruster_estimation", "thrusters"))
            for key, side in sides:
                self.adopt_report(data[key]["result_id"], report_dir / side)
            return data, data["result_id"], f"cross-check done: {data['verdict']}"

        self._run(job, "cross-check", "fitting both sets", fit)

    # -- the worker thread -------------------------------------------------------------------
    def _start(self, job: Job, work: Callable[..., None], *args: Any) -> None:
        """Store the new ``job``, hand ``work(*args)`` to the worker thread, publish the job."""
        self.registry.save(job, event=True)
        self._pool.submit(work, *args)
        self.registry.publish(job)

    def _run(self, job: Job, what: str, message: str, fit: Fit) -> None:
        """Run ``fit(store, report_dir)`` as ``job``: ``running`` with ``message``, then
        ``completed`` with the outcome, result id and message ``fit`` returns, or ``failed``
        with the error (logged unless it is bad input). The report folder goes and the finish
        time is stored either way."""
        store = self.registry.service.store
        assert store is not None
        update = self.registry.update
        update(job, state=JobState.RUNNING, started_at=time.time(), message=message)
        report_dir = self.report_root / f"job-{job.id}"
        try:
            data, result_id, done = fit(store, report_dir)
            data = without_report_files(data)  # scratch paths; the figures are stored
            update(
                job,
                state=JobState.COMPLETED,
                fraction=1.0,
                outcome=data,
                result_id=result_id,
                message=done,
            )
        except Exception as err:
            if not isinstance(err, ValueError | KeyError):
                log.exception("%s job %s failed", what, job.id)
            update(job, state=JobState.FAILED, message=f"error: {err}", error=str(err))
        finally:
            shutil.rmtree(report_dir, ignore_errors=True)
            update(job, finished_at=time.time())

    # -- report files (in the database) ------------------------------------------------------
    def adopt_report(self, result_id: int, folder: Path) -> list[str]:
        """Store ``folder``'s figures (PNG for the page, SVG beside it) as the report of
        ``result_id``; the figure names."""
        files = [
            (p.name, REPORT_SUFFIXES[p.suffix], p.read_bytes())
            for suffix in REPORT_SUFFIXES
            for p in sorted(Path(folder).glob(f"*{suffix}"))
        ]
        text = Path(folder) / REPORT_TEXT[0]
        extra = [(text.name, REPORT_TEXT[1], text.read_bytes())] if text.is_file() else []
        self.registry.repo.save_report_files(result_id, files + extra)
        return sorted({Path(name).stem for name, _, _ in files})

    def report_names(self, result_id: int) -> list[str]:
        """Names of the report figures stored with ``result_id``."""
        names = self.registry.repo.report_names(result_id)
        return sorted({Path(n).stem for n in names if Path(n).suffix in REPORT_SUFFIXES})

    def report_contents(self, result_id: int) -> list[tuple[str, bytes]]:
        """Every stored file of a result's report (report.md and the figures), by name."""
        stored = ((n, self.registry.repo.report_file(result_id, n))
                  for n in self.registry.repo.report_names(result_id))  # fmt: skip
        return [(name, found[1]) for name, found in stored if found is not None]

    def report_file(
        self, result_id: int, name: str, suffix: str = ".png"
    ) -> tuple[str, bytes] | None:
        """``(media type, bytes)`` of the figure ``name`` (``.png`` or ``.svg``) of a
        result's report, if stored."""
        if suffix not in REPORT_SUFFIXES:
            return None
        return self.registry.repo.report_file(result_id, f"{name}{suffix}")
