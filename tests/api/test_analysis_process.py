"""Estimations run in a worker process at lower priority, never in the rig service's
process, and their jobs still end as before: ``completed`` with the stored result's
document and id (its report figures stored with it), or ``failed`` with one line."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from api.core.analysis_executor import AnalysisTask, run_analysis, shared_process_executor
from daq.vocabulary import RunKind
from tests.api.conftest import AUTH, how_it_ended, wait_job
from tests.support.analysis_watch import Calls, Watching
from tests.support.waiting import wait_until

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime


@pytest.fixture
def watched(client, monkeypatch) -> Watching:
    analysis = client.app.state.runner.analysis
    watching = Watching(analysis.executor_for(client.app.state.service.store))
    monkeypatch.setattr(analysis, "executor", watching)
    return watching


def test_an_estimation_job_fits_in_a_niced_worker_process(client, tow_job, watched):
    body = {"run_ids": tow_job["run_ids"], "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)  # the first job starts the worker
    assert job["state"] == "completed", how_it_ended(job)
    [outcome] = watched.outcomes
    # The estimation ran in the process's worker, forked from its server.
    assert outcome.pid == shared_process_executor().worker_pid()
    assert _parent(outcome.pid) == _fork_server()
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


def test_a_defect_is_an_internal_error_not_bad_input(client, monkeypatch, tmp_path):
    """A bare KeyError (a lookup the code did not expect) says it is ours and is logged with
    its traceback, where a missing run (``RunNotFound``) is bad input naming the run."""
    import api.core.estimation_job

    def broken(*args, **kwargs):
        raise KeyError(RunKind.PENDULUM)

    monkeypatch.setattr(api.core.estimation_job, "run_estimation", broken)
    store = client.app.state.service.store
    task = AnalysisTask("estimation", {"run_ids": ["0123abcd"]}, store.url, Path(tmp_path))
    outcome = run_analysis(task, store)  # in this process: the patched fit
    assert not outcome.bad_input and outcome.traceback
    assert outcome.error == "internal error: KeyError: <RunKind.PENDULUM: 'pendulum'>"


def where_it_runs() -> tuple[int, int]:
    """(pid, niceness) of the process that runs this."""
    return os.getpid(), os.getpriority(os.PRIO_PROCESS, 0)


def fails_naming_a_field(_store) -> None:
    from estimation.errors import FieldError

    raise FieldError("delta", -1.0, "0 < delta ≤ 0.5")


class Unpicklable(ValueError):
    def __init__(self, field_name: str, why: str) -> None:
        super().__init__(f"{field_name}: {why}")


def fails_unpicklable(_store) -> None:
    raise Unpicklable("thresholds", "not increasing")


def patches_exception_pickling() -> None:
    """What a NetCDF export does to the worker once Dask is installed (the cluster extra):
    xarray imports dask, which installs tblib's exception pickling, so exceptions then
    pickle with their whole chain."""
    import tblib.pickling_support

    tblib.pickling_support.install()


@pytest.mark.parametrize("pickling", ["plain", "tblib"])
def test_a_call_runs_in_the_niced_worker_and_its_errors_come_back_as_they_were(client, pickling):
    """``call``: the work a route answers at once runs in the worker process, and the
    error it raises reaches the route as the same class (a field error stays a 422)."""
    from estimation.errors import FieldError

    store = client.app.state.service.store
    executor = shared_process_executor()
    if pickling == "tblib":  # a rehearsal's worker died here: BrokenProcessPool
        executor.call(None, patches_exception_pickling)
    pid, niceness = executor.call(None, where_it_runs)
    assert pid != os.getpid() and niceness > os.getpriority(os.PRIO_PROCESS, 0)
    with pytest.raises(FieldError, match=r"delta: got -1\.0, allowed: 0 < delta ≤ 0\.5"):
        executor.call(store.url, fails_naming_a_field)
    # a class that cannot be rebuilt from its message comes back as its built-in base
    with pytest.raises(ValueError, match="thresholds: not increasing") as raised:
        executor.call(store.url, fails_unpicklable)
    assert type(raised.value) is ValueError


def test_exports_studies_simulations_and_crosschecks_run_in_the_worker(
    client, tow_job, monkeypatch
):
    """What a route computes at once (a NetCDF/Parquet/MAT export, a sensitivity study, a
    6-DOF simulation, a cross-check's comparison and figure) runs through the analysis
    executor — in the worker process — never in the rig's process."""
    analysis = client.app.state.runner.analysis
    calls = Calls(analysis.executor_for(client.app.state.service.store))
    monkeypatch.setattr(analysis, "executor", calls)
    run_id = tow_job["run_ids"][0]
    r = client.get(f"/api/runs/{run_id}/export?format=parquet", headers=AUTH)
    assert r.status_code == 200 and r.content[:4] == b"PAR1", r.text[:200]
    r = client.post("/api/analysis/sensitivity", json={"vehicle": "seed002-rov"}, headers=AUTH)
    assert r.status_code == 200, r.text
    body = {"vehicle": "seed002-rov", "force": [10, 0, 0, 0, 0, 0], "duration_s": 2.0}
    r = client.post("/api/sixdof/simulate", json=body, headers=AUTH)
    assert r.status_code == 200 and r.json()["samples"] > 1, r.text
    assert calls.called == [
        "daq.export_formats.write_export",
        "api.core.analysis.analyse_vehicle",
        "api.core.sixdof.simulated_summary",
    ]
    r = client.get(f"/api/runs/{run_id}/export?format=nosuch", headers=AUTH)
    assert r.status_code == 422  # refused before any work is shipped
    assert len(calls.called) == 3


WORKER_OF_A_KILLED_SERVICE = (
    "from api.core.analysis_executor import ProcessExecutor\n"
    "import time\n"
    "executor = ProcessExecutor()  # held: a pool dropped shuts its own worker down\n"
    "print(executor.worker_pid(), flush=True)\n"
    "time.sleep(120)\n"
)


def test_the_worker_of_a_killed_service_ends_with_it():
    """A service killed with SIGKILL cannot shut its pool down; its worker notices the
    service is gone (the pipe it held closed) and ends, and so does the server it was forked
    from, which ends with its last client (rehearsals left a dozen such workers)."""
    import signal
    import subprocess
    import sys

    service = subprocess.Popen(
        [sys.executable, "-c", WORKER_OF_A_KILLED_SERVICE], stdout=subprocess.PIPE, text=True
    )
    try:
        assert service.stdout is not None
        worker = int(service.stdout.readline())
        os.kill(worker, 0)  # alive
        server = _parent(worker)
        assert _parent(server) == service.pid  # forked from the service's server
    finally:
        service.send_signal(signal.SIGKILL)
        service.wait(10)

    wait_until(lambda: _gone(worker), "the worker process ended", timeout_s=15)
    wait_until(lambda: _gone(server), "the worker's server ended", timeout_s=15)


def test_the_worker_is_forked_from_a_server_that_imported_the_fits_once(client):
    """The worker starts ready: it is forked from a server (``api.core.worker_processes``)
    that imported the fitting code before its first fork (its memory holds NumPy's and
    SciPy's compiled modules), so a new worker (a test's, or one replacing a killed worker)
    imports nothing. The server is an interpreter of its own (exec'd, not a fork of the
    threaded service) at ``SERVER_NICENESS``, below no child's niceness."""
    from api.core import worker_processes
    from api.core.analysis_executor import ANALYSIS_NICENESS
    from api.core.csv_upload import IMPORT_NICENESS

    worker = shared_process_executor().worker_pid()
    server = _parent(worker)
    assert server not in (os.getpid(), worker)
    assert _parent(worker) == server and _parent(server) == os.getpid()
    assert b"multiprocessing.forkserver" in Path(f"/proc/{server}/cmdline").read_bytes()
    maps = Path(f"/proc/{server}/maps").read_text()
    assert "_multiarray_umath" in maps and "/scipy/" in maps
    niceness = os.getpriority(os.PRIO_PROCESS, server)
    assert niceness == worker_processes.SERVER_NICENESS > os.getpriority(os.PRIO_PROCESS, 0)
    assert niceness <= min(ANALYSIS_NICENESS, IMPORT_NICENESS)


#: A service started (its app's lifespan, as ``rig serve`` starts it) and answering, then
#: its first test, then its first analysis: prints the processes it had started when idle,
#: once the test started, and the parent of the worker the analysis started.
IDLE_SERVICE = """
import json, os, sys
from pathlib import Path
from fastapi.testclient import TestClient
from api.core.analysis_executor import shared_process_executor
from api.http.app import create_app
from daq.session import RigSource
from tests.api.conftest import SHORT_TOW, TOKEN, how_it_ended, simulated_service, wait_job

def children():
    found = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text().rsplit(")", 1)[1].split()
            if int(stat[1]) == os.getpid() and stat[0] not in "ZX":
                found[entry.name] = (entry / "cmdline").read_bytes().decode()
        except (FileNotFoundError, ProcessLookupError):
            continue
    return found

service = simulated_service(RigSource.load(), f"sqlite:///{sys.argv[1]}/rig.db")
auth = {"Authorization": f"Bearer {TOKEN}"}
app = create_app(service, token=TOKEN, report_root=Path(sys.argv[1]))
with TestClient(app) as client:
    assert client.get("/api/health").status_code == 200
    idle = children()
    started = client.post("/api/jobs/tow", json=SHORT_TOW, headers=auth)
    assert started.status_code == 202, started.text
    testing, worker_started = children(), shared_process_executor().started
    job = wait_job(client, started.json()["id"])
    assert job["state"] == "completed", how_it_ended(job)
    worker = shared_process_executor().worker_pid()
    parent = int(Path(f"/proc/{worker}/stat").read_text().rsplit(")", 1)[1].split()[1])
    print(json.dumps({"idle": idle, "testing": testing, "worker_started": worker_started,
                      "worker_parent": parent}))
"""


def test_an_idle_service_starts_no_worker_and_its_first_test_the_workers_server(tmp_path):
    """An idle service holds no analysis worker nor the server workers fork from (together
    ~70 MB proportional, ``bench/serve_idle.py``): its first test starts the server, which
    imports the fitting code once while the test runs, and the first analysis the worker,
    forked from it. A fresh process: what a process starts is the behaviour (this one's
    server is shared by its tests)."""
    import json
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    done = subprocess.run(
        [sys.executable, "-c", IDLE_SERVICE, str(tmp_path)],
        cwd=root,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert [line for line in seen["idle"].values() if "multiprocessing" in line] == []
    testing = seen["testing"]
    [server] = [pid for pid, line in testing.items() if "multiprocessing.forkserver" in line]
    assert "api.core.estimation_job" in testing[server]  # it preloads the fits
    assert not seen["worker_started"]  # the worker waits for an analysis
    assert seen["worker_parent"] == int(server)  # then is forked from the server


def test_a_worker_runs_with_the_services_environment_as_at_its_start(client, monkeypatch):
    """A worker forked from the server started earlier still sees the service's environment
    as it is when the worker starts (as a spawned worker did), not the server's."""
    from api.core.analysis_executor import ProcessExecutor

    shared_process_executor().worker_pid()  # the server runs, started before the change
    monkeypatch.setenv("RIG_TEST_WORKER_ENVIRONMENT", "set after the server started")
    executor = ProcessExecutor()
    try:
        seen = executor.call(None, os.getenv, "RIG_TEST_WORKER_ENVIRONMENT")
    finally:
        executor.close()
    assert seen == "set after the server started"


def test_a_hung_task_is_killed_at_the_deadline_and_the_next_one_gets_a_new_worker():
    """A worker still busy after ``deadline_s`` is killed and replaced, and its task fails
    saying so; without the deadline one hung fit would hold every analysis job after it."""
    from api.core.analysis_executor import ProcessExecutor

    executor = ProcessExecutor(deadline_s=2.0)
    try:
        first = executor.worker_pid()
        # stdlib functions: unpickling one of this module's would import the test package
        with pytest.raises(RuntimeError, match=r"was killed after 2 s before sleep did \(taken"):
            executor.call(None, time.sleep, 600.0)  # a fit that never ends
        wait_until(lambda: _gone(first), "the hung worker killed", timeout_s=15)
        pid = executor.call(None, os.getpid)  # a new worker takes the next task
        assert pid not in (first, os.getpid())
    finally:
        executor.close()


def _parent(pid: int) -> int:
    """The parent process id of process ``pid``."""
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _fork_server() -> int:
    """The pid of this process's fork server (``api.core.worker_processes``), which must run."""
    servers = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:  # a process of the host may end meanwhile
            ours = _parent(int(entry.name)) == os.getpid() and not _gone(int(entry.name))
            if ours and b"multiprocessing.forkserver" in (entry / "cmdline").read_bytes():
                servers.append(int(entry.name))
        except (FileNotFoundError, ProcessLookupError):
            continue
    [server] = servers
    return server


def _gone(pid: int) -> bool:
    """Exited: no such process, or a zombie its parent has not reaped yet."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):  # gone before the open, or reaped after it
        return True
    return state in ("Z", "X")
