"""An estimation job is aborted like a procedure (``POST /api/jobs/{id}/abort``): one still
queued never runs; one running in the worker process has that process killed (the deadline's
kill path), ends ``aborted`` with nothing stored, and the next estimation runs on a new
worker; where the executor cannot stop a running fit the answer is 409 saying why and the job
runs on."""

from __future__ import annotations

import concurrent.futures
import os
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from api.core.analysis_executor import AnalysisTask, ProcessExecutor, TaskStop
from tests.api.conftest import AUTH, completed_estimation, how_it_ended, wait_job
from tests.api.test_analysis_process import _gone
from tests.support.analysis_watch import Watching
from tests.support.waiting import wait_until

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime

#: The file a ``slow_fit`` writes into its report folder once it began: the worker's pid.
BEGAN = "began"
REASON = "operator abort (API)"


def slow_fit(store, run_ids, *, report_dir, **params) -> None:
    """An estimation that says it began (``BEGAN``) and never ends by itself (the deadline
    test's ``time.sleep``): deterministically slow, however fast the host."""
    folder = Path(report_dir)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / BEGAN).write_text(str(os.getpid()))
    time.sleep(600)


def fits_slowly() -> None:
    """In the worker process: its estimations are ``slow_fit`` until the process ends (a new
    worker fits for real)."""
    import api.core.estimation_job

    api.core.estimation_job.run_estimation = slow_fit


def held_until(folder: str) -> int:
    """In the worker: another task (a route's call, a campaign's fit) that says it began
    (``BEGAN`` in ``folder``) and holds the worker until the test writes ``release`` there;
    the worker's pid."""
    (Path(folder) / BEGAN).write_text(str(os.getpid()))
    while not (Path(folder) / "release").exists():
        time.sleep(0.01)
    return os.getpid()


@pytest.fixture
def worker(client, monkeypatch) -> Iterator[Watching]:
    """A worker process of the test's own (the session's shared one is left alone), whose
    next estimation is ``slow_fit``, as the runner's executor (watched)."""
    executor = ProcessExecutor()
    watching = Watching(executor)
    monkeypatch.setattr(client.app.state.runner.analysis, "executor", watching)
    try:
        executor.call(None, fits_slowly)
        yield watching
    finally:
        executor.close()


def _start(client, run_ids: list[str]) -> str:
    body = {"run_ids": run_ids, "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    return r.json()["id"]


def _began(client, job_id: str) -> int:
    """The pid of the worker once it runs ``job_id``'s fit (``slow_fit`` says so)."""
    began = client.app.state.runner.report_root / f"job-{job_id}" / BEGAN
    text = wait_until(lambda: began.is_file() and began.read_text(), f"job {job_id}'s fit began")
    return int(text)


def _abort(client, job_id: str):
    return client.post(f"/api/jobs/{job_id}/abort", headers=AUTH)


def test_a_running_estimation_aborted_has_its_worker_killed_and_stores_nothing(
    client, tow_job, worker
):
    executor = worker.inner
    assert isinstance(executor, ProcessExecutor)
    store = client.app.state.service.store
    stored_before = [r.id for r in store.results(kind="estimation")]
    job_id = _start(client, tow_job["run_ids"])
    first = _began(client, job_id)
    assert first == executor.worker_pid() != os.getpid()

    r = _abort(client, job_id)
    assert r.status_code == 200, r.text
    job = wait_job(client, job_id)
    assert job["state"] == "aborted", how_it_ended(job)  # not failed
    assert job["error"] == REASON and job["progress"]["message"] == f"aborted: {REASON}"
    assert job["result_id"] is None and job["outcome"] is None
    [outcome] = worker.outcomes
    assert outcome.stopped
    wait_until(lambda: _gone(first), "the aborted fit's worker process killed", timeout_s=15)
    assert [r.id for r in store.results(kind="estimation")] == stored_before
    folder = client.app.state.runner.report_root / f"job-{job_id}"
    wait_until(lambda: not folder.exists(), "the aborted job's report folder removed")
    assert _abort(client, job_id).status_code == 409  # it ended

    done = completed_estimation(client, tow_job["run_ids"])  # a new worker fits for real
    assert executor.worker is not None and executor.worker[0] not in (first, os.getpid())
    assert list(store.result(done["result_id"]).run_ids) == tow_job["run_ids"]


def test_a_queued_estimation_aborted_never_runs(client, tow_job, worker):
    running = _start(client, tow_job["run_ids"])
    _began(client, running)  # the worker holds the one-at-a-time queue
    queued = _start(client, tow_job["run_ids"])
    assert client.get(f"/api/jobs/{queued}", headers=AUTH).json()["state"] == "queued"

    r = _abort(client, queued)
    assert r.status_code == 200, r.text
    assert r.json()["state"] == "aborted" and r.json()["error"] == REASON, r.json()
    assert _abort(client, running).status_code == 200
    job_end = wait_job(client, running)
    assert job_end["state"] == "aborted", how_it_ended(job_end)
    completed_estimation(client, tow_job["run_ids"])  # the job thread passed the queued one by

    job = client.get(f"/api/jobs/{queued}", headers=AUTH).json()
    assert job["state"] == "aborted" and job["started_at"] is None, job
    states = [e["state"] for e in client.get(f"/api/jobs/{queued}/events", headers=AUTH).json()]
    assert "running" not in states, states
    # the executor ran the aborted fit and the next one, never the queued one
    assert [o.stopped for o in worker.outcomes] == [True, False]
    r = _abort(client, queued)
    assert r.status_code == 409 and "already ended (aborted)" in r.text, r.text


def test_a_fit_the_executor_cannot_stop_answers_409_saying_why_and_runs_on(
    client, tow_job, monkeypatch
):
    """The thread executor (in-memory SQLite; here a fit held in this process) cannot stop
    a fit once started: 409 names why, and the job completes."""
    import api.core.estimation_job
    from api.core.analysis_executor import ThreadExecutor

    began, release = threading.Event(), threading.Event()

    def held_fit(store, run_ids, **params) -> dict:
        began.set()
        assert release.wait(60), "the test never released the fit"
        return {"held": True}

    executor = ThreadExecutor(client.app.state.service.store)
    monkeypatch.setattr(client.app.state.runner.analysis, "executor", executor)
    monkeypatch.setattr(api.core.estimation_job, "run_estimation", held_fit)
    job_id = _start(client, tow_job["run_ids"])
    try:
        assert began.wait(30), "the held fit never began"
        r = _abort(client, job_id)
        assert r.status_code == 409, r.text
        assert r.json()["detail"] == (
            f"job {job_id}: this estimation cannot be aborted: {executor.cannot_stop}"
        )
        assert "service's own process" in r.json()["detail"]
    finally:
        release.set()
    job = wait_job(client, job_id)
    assert job["state"] == "completed" and job["outcome"] == {"held": True}, job


@pytest.fixture
def slow_task(tmp_path) -> Iterator[tuple[ProcessExecutor, int, AnalysisTask, TaskStop]]:
    """A worker process of the test's own whose estimations are ``slow_fit``, its pid, an
    estimation task (its report folder ``tmp_path / "report"``) and the task's stop."""
    executor = ProcessExecutor()
    try:
        executor.call(None, fits_slowly)
        folder = tmp_path / "report"
        task = AnalysisTask("estimation", {"run_ids": []}, f"sqlite:///{tmp_path / 'db'}", folder)
        yield executor, executor.worker_pid(), task, TaskStop()
    finally:
        executor.close()


def test_a_call_waiting_behind_an_aborted_fit_runs_on_the_new_worker(slow_task):
    """A stop kills the worker only for its own task; what waited behind it there (a
    route's call, a campaign's fit) is not lost with it but runs on the new worker."""
    executor, first, task, stop = slow_task
    with concurrent.futures.ThreadPoolExecutor(2) as threads:
        fit = threads.submit(executor.run, task, stop)
        wait_until(lambda: (task.report_dir / BEGAN).is_file(), "the fit began")
        behind = threads.submit(executor.call, None, os.getpid)
        # the stdlib pool's submitted, unfinished tasks: the fit and the call behind it
        pending = executor._worker().pool._pending_work_items
        wait_until(lambda: len(pending) == 2, "the call waits behind the fit")
        stop.request("operator abort (test)")
        outcome = fit.result(30)
        assert outcome.stopped and outcome.error == "operator abort (test)", outcome
        assert behind.result(60) not in (first, os.getpid())
    wait_until(lambda: _gone(first), "the stopped fit's worker killed", timeout_s=15)


def test_a_stop_skips_its_task_not_begun_and_kills_no_other(slow_task, tmp_path):
    """Stopped while another task holds the worker, the task is skipped when its turn comes:
    the worker (and the other task) live on."""
    executor, first, task, stop = slow_task
    with concurrent.futures.ThreadPoolExecutor(2) as threads:
        held = threads.submit(executor.call, None, held_until, str(tmp_path))
        wait_until(lambda: (tmp_path / BEGAN).is_file(), "the other task began")
        fit = threads.submit(executor.run, task, stop)
        pending = executor._worker().pool._pending_work_items  # the stdlib pool's
        wait_until(lambda: len(pending) == 2, "the fit waits behind the other task")
        stop.request("operator abort (test)")
        (tmp_path / "release").write_text("")
        assert held.result(30) == first
        outcome = fit.result(30)
    assert outcome.stopped and outcome.error == "operator abort (test)", outcome
    assert not task.report_dir.exists()  # slow_fit never began
    assert executor.worker_pid() == first  # not killed


@pytest.mark.slow  # a browser page
def test_the_estimation_page_aborts_its_running_estimation(
    chromium, service, client, tow_job, worker, tmp_path
):
    """The Estimation page shows the running estimation with the header's Abort control
    beside its progress; pressing it ends the job ``aborted`` and the page says so."""
    from playwright.sync_api import expect

    from tests.api.conftest import signed_in_page

    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1366, "height": 900})
        page.route("**/api/stream**", lambda route: route.abort())  # the poll is enough
        page.click("nav a[data-page=estimation]")
        page.check(f"#est-runs input[value='{tow_job['run_ids'][0]}']")
        page.click("#est-run")
        expect(page.locator("#est-state")).to_have_text("running")
        [job] = [j for j in client.get("/api/jobs", headers=AUTH).json() if j["state"] == "running"]
        _began(client, job["id"])
        abort = page.locator("#est-status button[data-abort-job]")
        expect(abort).to_have_text("Abort")
        assert abort.get_attribute("class") == page.get_attribute("#abort-btn", "class")
        page.screenshot(path=str(tmp_path / "estimation-running.png"))
        abort.click()
        expect(page.locator("#est-state")).to_have_text("aborted")
        expect(page.locator("#est-status")).to_contain_text(f"aborted: {REASON}")
        expect(abort).to_have_count(0)
    job_end = wait_job(client, job["id"])
    assert job_end["state"] == "aborted", how_it_ended(job_end)
