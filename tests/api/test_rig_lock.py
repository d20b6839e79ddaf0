"""One rig, one driver across processes: while the service drives the rig, a ``rig tow`` or
a second ``rig serve`` (real subprocesses) on the same rig file is refused in one line that
names the holder, whatever database each records to, and the service's run goes on
undisturbed to ``completed``. On SQLite and PostgreSQL (the refused ``rig serve`` process on
SQLite: the host lock that refuses it is taken first whatever the database).

The rig file says hardware and points at a simulated rig running in this process (a
simulated rig file would start a simulator of its own in each process: no shared device).
"""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import sqlalchemy as sa
from fastapi.testclient import TestClient

from api.core.service import RigService, RigUnavailable
from api.http.app import create_app
from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.operator import OperatorAct, SimulatedOperator
from daq.session import RigSource
from daq.sim.simulated_rig import SimulatedRigThread
from daq.store import Store
from tests.api.conftest import AUTH, FINAL, TOKEN, how_it_ended, wait_job
from tests.procedures.conftest import hardware_rig_file
from tests.support.waiting import read_until

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]
RIG = str(Path(sys.executable).parent / "rig")  # the installed console script
TOW = {"force_n": 24.5, "max_time_s": 1.5, "baseline_s": 0.3}


@pytest.fixture
def rig_file(tmp_path) -> Path:
    """A hardware rig file whose PLC and thruster controller are a simulated rig's."""
    with SimulatedRigThread(load_rig(DEFAULT_RIG_FILE)) as sim:
        ends = sim.endpoints
        yield hardware_rig_file(tmp_path, ends.port, ends.thruster_serial_port)


def _refusal(program: str, activity: str | None = None) -> re.Pattern:
    """The one line a refused process prints, naming the PLC and this test process as the
    holder."""
    host = re.escape(socket.gethostname()[:24])
    tail = rf" \({re.escape(activity)}\)" if activity else ""
    return re.compile(
        rf"error: (cannot open the rig: )?rig 'BENBAM tow tank' \(PLC tcp 127\.0\.0\.1:\d+ "
        rf"unit 1 on host {host}\) is in use by `{program}` pid {os.getpid()} on host {host} "
        rf"since \d{{4}}-\d\d-\d\d \d\d:\d\d:\d\d{tail}"
    )


def _rig(*args: str, timeout_s: float = 120) -> subprocess.CompletedProcess:
    env = os.environ | {"RIG_API_TOKEN": TOKEN}
    return subprocess.run(
        [RIG, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout_s
    )


def _play_operator(
    client: TestClient,
    service: RigService,
    job_id: str,
    until: Callable[[dict], object] = lambda job: job["state"] in FINAL,
) -> dict:
    """Do each act the job asks for on the simulated rig, confirm it; return the job once
    ``until(job)`` (default: ended)."""
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

    return read_until(act_or_ended, until, "the job ready", timeout_s=60, poll_s=0.05)


def test_cli_tow_is_refused_while_the_service_drives_and_its_run_completes(
    db_url, rig_file, tmp_path
):
    # The service asks a person for each act, so its tow holds the rig as long as we like.
    service = RigService(RigSource.load(rig_file), db_url, ask_operator=True, owner="rig serve")
    with TestClient(create_app(service, token=TOKEN)) as client:
        job_id = client.post("/api/jobs/tow", json=TOW, headers=AUTH).json()["id"]
        wait_job(client, job_id, states=("waiting_for_operator",))

        # Another database: the lease is on the devices, so it is refused all the same.
        other_db = f"sqlite:///{tmp_path / 'other.db'}"
        args = ["--force", "10", "--max-time", "1", "--rig", str(rig_file), "--db", other_db]
        cli = _rig("tow", *args)
        assert cli.returncode == 1, cli.stdout + cli.stderr
        # one error line (after the note on the hung weight's rounding, said at the start)
        lines = [ln for ln in cli.stderr.strip().splitlines() if not ln.startswith("note: ")]
        assert len(lines) == 1, cli.stderr
        assert _refusal("rig serve", "tow 24.5 N").fullmatch(lines[0]), lines[0]
        assert cli.stdout == ""

        job = _play_operator(client, service, job_id)
    assert job["state"] == "completed", how_it_ended(job)
    with Store(db_url) as store:
        runs = store.list_runs()
        assert [r.id for r in runs] == job["run_ids"]
        assert runs[0].status == "completed"
        release = store.samples(runs[0].id).channels["tow_release"]
    with Store(other_db) as store:
        assert store.list_runs() == []  # the refused tow stored nothing
    # The carriage was released once and braked once: nobody else touched the brake.
    # A poll that failed under load stores NaN: it says nothing about the coil, so skip it.
    read = np.asarray(release, dtype=float)
    edges = np.diff(read[np.isfinite(read)].astype(int))
    assert (edges == 1).sum() == 1 and (edges == -1).sum() == 1, release


def test_two_services_cannot_drive_one_rig_whatever_their_databases(db_url, rig_file, tmp_path):
    first = RigService(RigSource.load(rig_file), db_url, owner="rig serve")
    other_db = f"sqlite:///{tmp_path / 'other.db'}"
    second = RigService(RigSource.load(rig_file), other_db, owner="rig serve")
    first.start()
    try:
        with pytest.raises(RigUnavailable, match=_refusal("rig serve").pattern[len("error: ") :]):
            second.start()
        second.stop()
        assert first.running and first.session.rig_lock.held
    finally:
        first.stop()
    # Stopping gives the rig back: the next service opens it.
    third = RigService(RigSource.load(rig_file), other_db, owner="rig serve")
    third.start()
    try:
        assert third.running
    finally:
        third.stop()


def test_a_second_rig_serve_is_refused_in_one_line_announcing_nothing(rig_file, tmp_path):
    """The ``rig serve`` process on SQLite only: a second process on this host is refused by
    the host lock, taken before the PostgreSQL part whatever the database
    (``daq.rig_lock``); the services above meet the lease on both backends."""
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    first = RigService(RigSource.load(rig_file), db, owner="rig serve")
    first.start()
    try:
        served = _rig("serve", "--port", "0", "--rig", str(rig_file), "--db", db,
                      "--no-realtime")  # fmt: skip
        assert served.returncode == 1, served.stdout + served.stderr
        lines = served.stderr.strip().splitlines()
        assert len(lines) == 1 and _refusal("rig serve").fullmatch(lines[0]), served.stderr
        assert "rig service: http" not in served.stdout  # nothing announced
        assert first.running and first.session.rig_lock.held
    finally:
        first.stop()


def test_a_lost_lock_ends_the_service_job_and_frees_the_rig(rig_file, postgres_server):
    """The service's PostgreSQL lock connection terminated mid-tow: the job's run ends
    ``aborted`` naming the lost lock, the service says why it no longer drives the rig, a
    new job is refused in one line, and a second service may take the rig."""
    url = postgres_server.create_database()
    service = RigService(RigSource.load(rig_file), url, ask_operator=True, owner="rig serve")
    try:
        with TestClient(create_app(service, token=TOKEN)) as client:
            job_id = client.post("/api/jobs/tow", json=TOW, headers=AUTH).json()["id"]
            job = _play_operator(
                client, service, job_id, until=lambda j: j["state"] == "running" and j["run_ids"]
            )
            backend = service.require_session().rig_lock.pg.backend_pid
            with sa.create_engine(postgres_server.admin_url).connect() as admin:
                admin.execute(sa.text("SELECT pg_terminate_backend(:p)"), {"p": backend})
            job = wait_job(client, job_id)
            assert job["state"] == "aborted", how_it_ended(job)
            assert job["error"].startswith("rig lock lost: the PostgreSQL connection holding")
            (run,) = client.get("/api/runs", headers=AUTH).json()
            assert (run["status"], run["reason"]) == ("aborted", job["error"])
            rig = client.get("/api/rig", headers=AUTH).json()
            assert not rig["running"] and rig["error"].startswith("rig lock lost: ")
            refused = client.post("/api/jobs/tow", json=TOW, headers=AUTH)
            assert refused.status_code == 503, refused.text
            assert refused.json()["detail"].startswith("rig lock lost: ")
            assert "\n" not in refused.json()["detail"]
            second = RigService(RigSource.load(rig_file), url, owner="rig serve")
            second.start()  # the first one released the devices
            second.stop()
    finally:
        service.stop()
        postgres_server.drop_database(url)
