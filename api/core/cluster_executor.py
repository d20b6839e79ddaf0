"""Analyses on other machines: a Dask distributed cluster as the analysis executor.

``rig serve --analysis-workers tcp://HOST:8786`` sends every analysis (an estimation, a
cross-check, a campaign's fit, a route's export, study or simulation) to the Dask scheduler
at that address instead of the embedded worker process (``api.core.analysis_executor``):
a lab that outgrows one machine adds workers without a second code path. The task is the
same plain data and the same function (:func:`~api.core.analysis_executor.run_analysis`,
:func:`~api.core.analysis_executor.call_on_store`) runs on the worker.

What a worker needs: this package installed at the service's version, and the database at
the service's URL within reach (a PostgreSQL server the lab shares; a SQLite file only on
the service's own machine). Report figures are drawn on the worker into a scratch folder
there and come back as bytes with the outcome (:func:`run_shipping_reports`); the service
writes them into its own report folder and stores them as on one machine.

Failures: a scheduler that cannot be reached when the service starts is
:class:`ClusterUnavailable` (one line naming the address); a worker lost mid-task, or a
task the cluster cannot run, is that job's failed outcome (one line), never a traceback.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from api.core.analysis_executor import (
    AnalysisOutcome,
    AnalysisTask,
    TaskStop,
    call_on_store,
    run_analysis,
)

if TYPE_CHECKING:
    from distributed import Client

T = TypeVar("T")

#: A report shipped back: (result id, its folder relative to the task's report folder,
#: {file name: bytes}).
ShippedReport = tuple[int, str, dict[str, bytes]]

#: How long the service waits for the scheduler when it starts, s.
CONNECT_TIMEOUT_S = 10.0


class ClusterUnavailable(RuntimeError):
    """The Dask scheduler named by ``--analysis-workers`` cannot be reached."""


def run_shipping_reports(task: AnalysisTask) -> tuple[AnalysisOutcome, list[ShippedReport]]:
    """On a worker: ``run_analysis(task)`` with its figures drawn into a scratch folder of
    this machine, and those figures as bytes (the service's folder is not here)."""
    with tempfile.TemporaryDirectory(prefix="towrig-remote-") as scratch:
        local = replace(task, report_dir=Path(scratch) / task.report_dir.name)
        outcome = run_analysis(local)
        shipped = []
        for result_id, folder in outcome.reports:
            files = {p.name: p.read_bytes() for p in Path(folder).glob("*") if p.is_file()}
            shipped.append((result_id, str(Path(folder).relative_to(local.report_dir)), files))
    return outcome, shipped


def land_reports(task: AnalysisTask, shipped: list[ShippedReport]) -> tuple[tuple[int, Path], ...]:
    """On the service: write shipped figures under ``task.report_dir``; the (result id,
    folder) pairs the outcome names, now local."""
    landed = []
    for result_id, relative, files in shipped:
        folder = task.report_dir / relative
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / Path(name).name).write_bytes(data)
        landed.append((result_id, folder))
    return tuple(landed)


class DaskExecutor:
    """Runs analyses on the Dask distributed cluster whose scheduler is at ``address``
    (``tcp://host:8786``); one task at a time per caller, as the embedded worker."""

    cannot_stop: str | None = (
        "its fit runs on a worker of the Dask cluster, which this service does not stop"
    )

    def __init__(self, address: str, *, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
        from distributed import Client  # the cluster's client only where one is asked for

        self.address = address
        try:
            self._client: Client = Client(address, timeout=timeout_s, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as err:
            raise ClusterUnavailable(
                f"--analysis-workers: no Dask scheduler answers at {address!r} "
                f"within {timeout_s:g} s ({err})"
            ) from None

    def worker_pids(self) -> list[int]:
        """The pid of each worker process of the cluster (on its own machine)."""
        return sorted(self._client.run(os.getpid).values())

    def run(self, task: AnalysisTask, stop: TaskStop | None = None) -> AnalysisOutcome:
        try:  # ``cannot_stop``: the stop is not heard
            future = self._client.submit(run_shipping_reports, task, pure=False)
            outcome, shipped = future.result()
        except Exception as err:  # a worker lost, a task the cluster could not run
            line = f"the analysis cluster at {self.address} did not finish the {task.kind}: {err}"
            return AnalysisOutcome(None, None, f"error: {line}", os.getpid(), 0, error=line)
        return replace(outcome, reports=land_reports(task, shipped))

    def call(self, store_url: str | None, fn: Callable[..., T], /, *args: Any) -> T:
        future = self._client.submit(call_on_store, store_url, fn, args, pure=False)
        result: T = future.result()
        return result

    def close(self) -> None:
        """Disconnect from the scheduler (the cluster and its workers go on)."""
        self._client.close()
