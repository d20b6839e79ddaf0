"""The analysis worker: estimations and cross-checks as jobs, one at a time, and the report
figures they draw, stored in the database with their result. A job thread writes the job's
states; the fit itself runs where the executor says (``api.core.analysis_executor``): in a
worker process at lower priority, never in the rig's process (in-memory SQLite aside).

A job here needs no rig: it waits ``queued`` behind the analysis before it, runs, and ends
``completed`` with its outcome and result id, ``failed`` with the error, or ``aborted``
(:meth:`AnalysisWorker.abort`): a queued job never runs; a running one's worker process is
killed (``ProcessExecutor``; the thread and Dask executors cannot stop a fit: 409) and
nothing of it is stored, unless its fit ended first.
"""

from __future__ import annotations

import concurrent.futures
import logging
import shutil
import threading
import time
from pathlib import Path
from typing import Any

from api.core.analysis_executor import (
    AnalysisExecutor,
    AnalysisKind,
    AnalysisTask,
    ProcessExecutor,
    TaskStop,
    executor_for,
    shared_process_executor,
)
from api.core.job_model import Job, JobConflict, without_report_files
from api.core.job_registry import JobRegistry
from daq.store import Store
from daq.store.schema import JOB_FINAL, JobState

log = logging.getLogger(__name__)

#: Report figures a result serves (the raster for the page, the vector beside it): media types.
REPORT_SUFFIXES = {".png": "image/png", ".svg": "image/svg+xml"}
#: The report's text, stored beside its figures so the report can be downloaded later.
REPORT_TEXT = ("report.md", "text/markdown; charset=utf-8")
#: Job kinds this worker runs.
ANALYSES = ("estimation", "crosscheck")


class AnalysisWorker:
    """Runs estimation and cross-check jobs of ``registry``, one at a time, through its
    executor; drawn reports go to ``report_root`` first, then into the database."""

    def __init__(self, registry: JobRegistry, report_root: Path) -> None:
        self.registry = registry
        self.report_root = report_root
        #: Where fits run (:mod:`api.core.analysis_executor`); made at the first job.
        self.executor: AnalysisExecutor | None = None
        self._executor_lock = threading.Lock()
        #: The stop of each job not yet ended, by id, and the job whose fit began (under
        #: ``_lock``: a job is aborted in the queue or started, never both).
        self._stops: dict[str, TaskStop] = {}
        self._began: str | None = None
        self._lock = threading.Lock()
        # One job at a time; this thread only waits for the executor and writes the registry.
        self._pool = concurrent.futures.ThreadPoolExecutor(1, thread_name_prefix="estimate")

    def prepare(self, store: Store) -> None:
        """Start the server the executor's worker forks from (``ProcessExecutor.prepare``),
        not the worker: called as the first test starts, so the server's imports overlap
        the test, not the first estimate, and an idle service holds neither (~70 MB
        proportional, ``bench/serve_idle.py``)."""
        executor = self.executor_for(store)
        if isinstance(executor, ProcessExecutor):
            executor.prepare()

    def close(self) -> None:
        """Drop the jobs not started and wait for the one running. The process's shared
        worker stays for the next service of this process (``shared_process_executor``);
        an executor of this worker's own (a test's) is closed."""
        self._pool.shutdown(wait=True, cancel_futures=True)
        with self._executor_lock:
            executor, self.executor = self.executor, None
        if executor is not None and executor is not shared_process_executor():
            executor.close()

    # -- estimation ------------------------------------------------------------------------
    def start_estimation(
        self,
        run_ids: list[str],
        method: str,
        search_effects: bool,
        user: str | None = None,
        exclude_outliers: bool = False,
    ) -> Job:
        """Run an estimation in the analysis worker (never in the rig's process), for ``user``;
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
        self._start(job, "estimation", "fitting", params)
        return job

    # -- cross-check -------------------------------------------------------------------------
    def start_crosscheck(
        self,
        weight_runs: list[str],
        thruster_runs: list[str],
        search_effects: bool = True,
        user: str | None = None,
    ) -> Job:
        """Estimate both sets of runs and cross-check them, in the analysis worker."""
        params = {
            "weight_runs": weight_runs,
            "thruster_runs": thruster_runs,
            "search_effects": search_effects,
        }
        label = f"cross-check {len(weight_runs)} weight vs {len(thruster_runs)} thruster run(s)"
        job = self.registry.new("crosscheck", label, params, user_name=user)
        job.run_ids = list(dict.fromkeys([*weight_runs, *thruster_runs]))
        self._start(job, "crosscheck", "fitting both sets", params)
        return job

    # -- the job thread ------------------------------------------------------------------
    def _start(self, job: Job, kind: AnalysisKind, message: str, params: dict[str, Any]) -> None:
        """Store the new ``job``, hand it to the job thread, publish the job."""
        self.registry.save(job, event=True)
        with self._lock:
            self._stops[job.id] = TaskStop()
        self._pool.submit(self._run, job, kind, message, params)
        self.registry.publish(job)

    def _run(self, job: Job, kind: AnalysisKind, message: str, params: dict[str, Any]) -> None:
        """Run the analysis as ``job`` through the executor (not if it was aborted while
        queued): ``running`` with ``message``, then ``completed`` with the outcome, result id
        and closing message, ``aborted`` once stopped, or ``failed`` with the error (logged
        with the worker's traceback unless it is bad input). The report figures go into the
        database, the report folder goes and the finish time is stored either way."""
        with self._lock:
            stop = self._stops[job.id]
            if stop.reason is not None:  # aborted while queued: :meth:`abort` ended it
                del self._stops[job.id]
                return
            self._began = job.id
        try:
            self._fit(job, kind, message, params, stop)
        finally:
            with self._lock:
                del self._stops[job.id]
                self._began = None

    def _fit(
        self, job: Job, kind: AnalysisKind, message: str, params: dict[str, Any], stop: TaskStop
    ) -> None:
        """:meth:`_run`'s fit of ``job``, its ``stop`` handed to the executor."""
        store = self.registry.service.store
        assert store is not None
        update = self.registry.update
        update(job, state=JobState.RUNNING, started_at=time.time(), message=message)
        report_dir = self.report_root / f"job-{job.id}"
        try:
            task = AnalysisTask(kind, params, store.url, report_dir)
            outcome = self.executor_for(store).run(task, stop)
            if outcome.stopped:  # nothing stored: the worker was killed before its end
                update(job, state=JobState.ABORTED, message=outcome.message, error=outcome.error)
                return
            if outcome.error is not None:
                if not outcome.bad_input:
                    log.error(
                        "%s job %s failed: %s", kind, job.id, outcome.traceback or outcome.error
                    )
                update(job, state=JobState.FAILED, message=outcome.message, error=outcome.error)
                return
            for result_id, folder in outcome.reports:
                self.adopt_report(result_id, folder)
            update(
                job,
                state=JobState.COMPLETED,
                fraction=1.0,
                outcome=without_report_files(outcome.data or {}),  # the figures are stored
                result_id=outcome.result_id,
                message=outcome.message,
            )
        except Exception as err:  # the registry or the report store, not the fit
            log.exception("%s job %s failed", kind, job.id)
            update(job, state=JobState.FAILED, message=f"error: {err}", error=str(err))
        finally:
            shutil.rmtree(report_dir, ignore_errors=True)
            update(job, finished_at=time.time())

    def abort(self, job: Job, reason: str) -> Job:
        """Abort the estimation or cross-check ``job`` for ``reason``: one still queued ends
        ``aborted`` now and never runs; one running is stopped by the executor (its worker
        process killed; the job thread then ends it ``aborted``). ``JobConflict`` (409) for a
        job that ended, and for one running where the executor cannot stop it, saying why."""
        with self._lock:
            stop = self._stops.get(job.id)
            if job.state in JOB_FINAL:
                raise JobConflict(f"job {job.id} already ended ({job.state})")
            if stop is None:  # a job row this service did not start
                raise JobConflict(f"job {job.id} ({job.state}) is not run by this service")
            began = self._began == job.id
            if not began:  # the job thread will pass it by
                stop.request(reason)
        if not began:
            self.registry.update(
                job, state=JobState.ABORTED, message=f"aborted: {reason}", error=reason
            )
            return job
        store = self.registry.service.store
        assert store is not None
        why = self.executor_for(store).cannot_stop
        if why is not None:
            raise JobConflict(f"job {job.id}: this {job.kind} cannot be aborted: {why}")
        self.registry.update(job, message=f"aborting: {reason}")
        stop.request(reason)  # the worker process is killed; the job thread ends the job
        return job

    def executor_for(self, store: Store) -> AnalysisExecutor:
        """The executor of this worker: ``executor`` if set, else (made once) a worker process
        for a database other processes can open, the job thread for in-memory SQLite."""
        with self._executor_lock:
            if self.executor is None:
                self.executor = executor_for(store)
            return self.executor

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
