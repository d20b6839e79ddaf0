"""Estimations run in a worker process at lower priority, never in the rig service's
process, and their jobs still end as before: ``completed`` with the stored result's
document and id (its report figures stored with it), or ``failed`` with one line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from api.core.analysis_executor import (
    AnalysisExecutor,
    AnalysisOutcome,
    AnalysisTask,
    shared_process_executor,
)
from tests.api.conftest import AUTH, wait_job

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime


class Watching:
    """The runner's executor, recording the outcome of each task it runs."""

    def __init__(self, inner: AnalysisExecutor) -> None:
        self.inner = inner
        self.outcomes: list[AnalysisOutcome] = []

    def run(self, task: AnalysisTask) -> AnalysisOutcome:
        outcome = self.inner.run(task)
        self.outcomes.append(outcome)
        return outcome

    def close(self) -> None:
        self.inner.close()


@pytest.fixture
def watched(client, monkeypatch) -> Watching:
    analysis = client.app.state.runner.analysis
    watching = Watching(analysis.executor_for(client.app.state.service.store))
    monkeypatch.setattr(analysis, "executor", watching)
    return watching


def test_an_estimation_job_fits_in_a_niced_worker_process(client, tow_job, watched):
    assert shared_process_executor().started  # by the service's start, before any job
    started_worker = shared_process_executor().worker_pid()
    body = {"run_ids": tow_job["run_ids"], "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)  # the first job starts the worker
    assert job["state"] == "completed", job
    [outcome] = watched.outcomes
    # The service started this process's worker before any job asked for it (its imports
    # overlapped the tow), and the estimation ran in that worker.
    assert outcome.pid == started_worker
    assert outcome.pid != os.getpid()
    assert outcome.niceness > os.getpriority(os.PRIO_PROCESS, 0)
    store = client.app.state.service.store
    stored = store.result(job["result_id"])
    assert job["result_id"] == outcome.result_id
    assert job["outcome"] == stored.data | {"result_id": stored.id}
    assert list(stored.run_ids) == tow_job["run_ids"]
    # figures drawn by the worker, stored by the service
    assert client.app.state.runner.report_names(stored.id)


def test_a_fit_that_fails_in_the_worker_is_an_outcome_naming_the_run(client, watched, tmp_path):
    store = client.app.state.service.store
    task = AnalysisTask("estimation", {"run_ids": ["0123abcd"]}, store.url, Path(tmp_path))
    outcome = watched.run(task)
    assert outcome.pid != os.getpid()
    assert outcome.bad_input and outcome.result_id is None
    assert "0123abcd" in (outcome.error or "")
