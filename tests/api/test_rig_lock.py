"""One rig, one driver across processes: while the service drives the rig, a ``rig tow`` or
a second ``rig serve`` (real subprocesses) on the same database is refused in one line that
names the holder, and the service's run goes on undisturbed to ``completed``. On SQLite and
PostgreSQL."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from api.core.service import RigService, RigUnavailable
from api.http.app import create_app
from daq.operator import OperatorAct, SimulatedOperator
from daq.session import RigSource
from daq.store import Store
from tests.api.conftest import AUTH, FINAL, TOKEN, wait_job
from tests.waiting import read_until

ROOT = Path(__file__).resolve().parents[2]
RIG = str(Path(sys.executable).parent / "rig")  # the installed console script
TOW = {"force_n": 24.5, "max_time_s": 1.5, "baseline_s": 0.3}


def _refusal(program: str, activity: str | None = None) -> re.Pattern:
    """The one line a refused process prints, naming this test process as the holder."""
    host = re.escape(socket.gethostname()[:24])
    tail = rf" \({re.escape(activity)}\)" if activity else ""
    return re.compile(
        rf"error: (cannot open the rig: )?rig 'BENBAM tow tank' is in use by `{program}` "
        rf"pid {os.getpid()} on host {host} since \d{{4}}-\d\d-\d\d \d\d:\d\d:\d\d{tail}"
    )


def _rig(*args: str, timeout_s: float = 120) -> subprocess.CompletedProcess:
    env = os.environ | {"RIG_API_TOKEN": TOKEN}
    return subprocess.run(
        [RIG, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout_s
    )


def _play_operator(client: TestClient, service: RigService, job_id: str) -> dict:
    """Do each act the job asks for on the simulated rig, confirm it; return the ended job."""
    done: set[str] = set()

    def act_or_ended() -> dict:
        job = client.get(f"/api/jobs/{job_id}", headers=AUTH).json()
        act = job["operator_act"]
        if job["state"] == "waiting_for_operator" and act and act["name"] not in done:
            session = service.require_session()
            assert session.plc is not None
            todo = OperatorAct(act["name"], act["instruction"], act["value"])
            service.run(SimulatedOperator(session.plc).perform(todo))
            done.add(act["name"])
            assert client.post(f"/api/jobs/{job_id}/confirm", headers=AUTH).status_code == 200
        return job

    return read_until(
        act_or_ended, lambda job: job["state"] in FINAL, "the job ended", timeout_s=60, poll_s=0.05
    )


def test_cli_tow_is_refused_while_the_service_drives_and_its_run_completes(db_url):
    # The service asks a person for each act, so its tow holds the rig as long as we like.
    service = RigService(RigSource.load(), db_url, ask_operator=True, owner="rig serve")
    with TestClient(create_app(service, token=TOKEN)) as client:
        job_id = client.post("/api/jobs/tow", json=TOW, headers=AUTH).json()["id"]
        wait_job(client, job_id, states=("waiting_for_operator",))

        cli = _rig("tow", "--force", "10", "--max-time", "1", "--db", db_url)
        assert cli.returncode == 1, cli.stdout + cli.stderr
        # one error line (after the note on the hung weight's rounding, said at the start)
        lines = [ln for ln in cli.stderr.strip().splitlines() if not ln.startswith("note: ")]
        assert len(lines) == 1, cli.stderr
        assert _refusal("rig serve", "tow 24.5 N").fullmatch(lines[0]), lines[0]
        assert cli.stdout == ""

        job = _play_operator(client, service, job_id)
    assert job["state"] == "completed", job
    with Store(db_url) as store:
        runs = store.list_runs()
        assert [r.id for r in runs] == job["run_ids"]  # the refused tow stored nothing
        assert runs[0].status == "completed"
        release = store.samples(runs[0].id).channels["tow_release"]
    # The carriage was released once and braked once: nobody else touched the brake.
    # A poll that failed under load stores NaN: it says nothing about the coil, so skip it.
    read = np.asarray(release, dtype=float)
    edges = np.diff(read[np.isfinite(read)].astype(int))
    assert (edges == 1).sum() == 1 and (edges == -1).sum() == 1, release


def test_two_services_on_one_database_cannot_drive_one_rig(db_url):
    first = RigService(RigSource.load(), db_url, owner="rig serve")
    second = RigService(RigSource.load(), db_url, owner="rig serve")
    first.start()
    try:
        with pytest.raises(RigUnavailable, match=_refusal("rig serve").pattern[len("error: ") :]):
            second.start()
        second.stop()
        assert first.running and first.session.rig_lock.held

        served = _rig("serve", "--port", "0", "--db", db_url, "--no-realtime")
        assert served.returncode == 1, served.stdout + served.stderr
        lines = served.stderr.strip().splitlines()
        assert len(lines) == 1 and _refusal("rig serve").fullmatch(lines[0]), served.stderr
        assert "rig service: http" not in served.stdout  # nothing announced
    finally:
        first.stop()
    # Stopping gives the rig back: the next service opens it.
    third = RigService(RigSource.load(), db_url, owner="rig serve")
    third.start()
    try:
        assert third.running
    finally:
        third.stop()
