"""The durable job queue, through real ``rig serve`` subprocesses on SQLite and PostgreSQL:
a tow posted while another runs is queued and then runs; the queue is reordered, trimmed,
paused by an aborted job and resumed; a service killed mid-job (kill -9) lists the job
``interrupted`` after a restart and keeps its queued jobs queued and paused. On SQLite the
chain goes on: after a clean stop an estimation job is listed ``completed`` and its report
plots still download. (That stop and its report are the service's, not the backend's: the
report files' storage on PostgreSQL is tests/store/test_job_repository.py, in process.)
The estimation fits two tows imported into the restarted service, not the tows it recorded:
those are recorded in real time, and on a loaded host their skipped clock slots are named and
left out, and rightly refuse the fit ("samples in free motion left out", load 13)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from tests.api.conftest import how_it_ended
from tests.integration.test_import_kinds import _tow_csv
from tests.support.serve import stop_service, wait_for_service
from tests.support.waiting import read_until

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]
TOKEN = "queue-test-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
ENDED = ("completed", "aborted", "failed", "interrupted")


def tow(force_n: float, max_time_s: float = 1.5) -> dict:
    return {"force_n": force_n, "max_time_s": max_time_s, "baseline_s": 0.3}


@contextmanager
def served(db_url: str, data_home: Path) -> Iterator[tuple[subprocess.Popen, httpx.Client]]:
    """A ``rig serve`` subprocess on ``db_url`` and a client for it; stopped (SIGTERM) at
    the end unless the test killed it."""
    env = os.environ | {
        "RIG_API_TOKEN": TOKEN,
        "XDG_DATA_HOME": str(data_home),
        "PYTHONUNBUFFERED": "1",
    }
    proc = subprocess.Popen(
        [sys.executable, "-m", "api.cli.serve", "--port", "0", "--db", db_url, "--no-realtime"],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,  # its log (e.g. the interrupted runs it recovered)
        text=True,
    )
    # keep reading its log so a chatty service never blocks on a full pipe
    threading.Thread(target=proc.stderr.read, daemon=True).start()
    try:
        url = wait_for_service(proc)  # it drains stdout from then on
        with httpx.Client(base_url=url, headers=AUTH, timeout=30) as client:
            yield proc, client
    finally:
        if proc.poll() is None:
            stop_service(proc)


def job(client: httpx.Client, job_id: str) -> dict:
    r = client.get(f"/api/jobs/{job_id}")
    assert r.status_code == 200, r.text
    return r.json()


def wait_for(client: httpx.Client, job_id: str, ok, timeout_s: float = 60.0) -> dict:
    """Poll the job until ``ok(job)`` (the API has no push for a test to wait on)."""
    return read_until(
        lambda: job(client, job_id), ok, f"job {job_id} moving on", timeout_s=timeout_s, poll_s=0.05
    )


def ended(client: httpx.Client, job_id: str, timeout_s: float = 60.0) -> dict:
    return wait_for(client, job_id, lambda j: j["state"] in ENDED, timeout_s)


def post_tow(client: httpx.Client, body: dict, **params) -> dict:
    r = client.post("/api/jobs/tow", json=body, params=params)
    assert r.status_code == 202, r.text
    return r.json()


def queue_ids(client: httpx.Client) -> list[str]:
    return [j["id"] for j in client.get("/api/queue").json()["jobs"]]


@contextmanager
def crashed_and_recovered(
    db_url: str, tmp_path: Path
) -> Iterator[tuple[httpx.Client, dict[str, dict]]]:
    """The queue driven, the service killed mid-job (kill -9) and restarted, the queued job
    resumed to ``completed``: the restarted service's client and the jobs by letter, until
    its clean stop (SIGTERM) at the end of the block."""
    with served(db_url, tmp_path) as (proc, client):
        # A holds the rig for a long tow; B, C queue behind it in order.
        a = post_tow(client, tow(4.9, max_time_s=60))
        b = post_tow(client, tow(24.5))
        c = post_tow(client, tow(83.3))
        assert (b["state"], b["position"]) == ("queued", 1)
        assert (c["state"], c["position"]) == ("queued", 2)
        refused = client.post("/api/jobs/tow", json=tow(24.5), params={"queue": "false"})
        assert refused.status_code == 409 and a["id"] in refused.json()["detail"], refused.text
        queue = client.get("/api/queue").json()
        assert queue["running"]["id"] == a["id"] and not queue["paused"]
        assert queue_ids(client) == [b["id"], c["id"]]

        # Reorder and remove over HTTP.
        moved = client.post(f"/api/queue/{c['id']}/move", json={"position": 1})
        assert moved.status_code == 200, moved.text
        assert [j["id"] for j in moved.json()["jobs"]] == [c["id"], b["id"]]
        assert [j["position"] for j in moved.json()["jobs"]] == [1, 2]
        bad = client.post(f"/api/queue/{c['id']}/move", json={"position": 3})
        assert bad.status_code == 422 and "position" in bad.text and "≤ 2" in bad.text
        assert client.delete(f"/api/queue/{b['id']}").status_code == 200
        assert client.get(f"/api/jobs/{b['id']}").status_code == 404
        assert client.delete(f"/api/queue/{a['id']}").status_code == 409  # not queued
        assert queue_ids(client) == [c["id"]]

        # An aborted job pauses the queue: C waits for the operator.
        wait_for(client, a["id"], lambda j: j["state"] == "running" and j["run_ids"])
        assert client.post(f"/api/jobs/{a['id']}/abort").status_code == 200
        assert ended(client, a["id"])["state"] == "aborted"
        queue = client.get("/api/queue").json()
        assert queue["paused"] and a["id"] in queue["reason"], queue
        assert job(client, c["id"])["state"] == "queued"

        # Resumed, C runs; D, posted while C runs, is queued and then runs by itself.
        assert not client.post("/api/queue/resume").json()["paused"]
        wait_for(client, c["id"], lambda j: j["state"] != "queued")
        d = post_tow(client, tow(4.9, max_time_s=60))
        assert d["state"] == "queued" and d["position"] == 1
        c_end = ended(client, c["id"])
        assert c_end["state"] == "completed", how_it_ended(c_end)
        running_d = wait_for(client, d["id"], lambda j: j["state"] == "running" and j["run_ids"])
        e = post_tow(client, tow(24.5))
        assert e["state"] == "queued"

        proc.send_signal(signal.SIGKILL)  # killed mid-job
        proc.wait(10)

    with served(db_url, tmp_path) as (proc, client):
        d_after = job(client, d["id"])
        assert d_after["state"] == "interrupted", d_after
        assert d_after["run_ids"] == running_d["run_ids"]
        run = client.get(f"/api/runs/{d_after['run_ids'][0]}").json()
        assert run["status"] == "interrupted", run
        listed = {j["id"]: j["state"] for j in client.get("/api/jobs").json()}
        assert {k: listed[k] for k in (a["id"], c["id"], d["id"], e["id"])} == {
            a["id"]: "aborted",
            c["id"]: "completed",
            d["id"]: "interrupted",
            e["id"]: "queued",
        }
        # Paged and filtered: ?limit, ?offset, ?state (a bad one is a 422 naming it).
        newest = [j["id"] for j in client.get("/api/jobs").json()]
        assert len(newest) >= 4

        def ids(**params) -> list[str]:
            return [j["id"] for j in client.get("/api/jobs", params=params).json()]

        assert ids(limit=2) == newest[:2] and ids(limit=2, offset=1) == newest[1:3]
        assert ids(state="queued") == [e["id"]]
        assert ids(state="interrupted") == [d["id"]]
        bad = client.get("/api/jobs", params={"limit": 0})
        assert bad.status_code == 422 and "limit" in bad.text
        # The queued job survived, but the rig does not move by itself after a crash.
        queue = client.get("/api/queue").json()
        assert queue["paused"] and queue["running"] is None, queue
        assert queue_ids(client) == [e["id"]]
        assert job(client, e["id"])["created_at"].endswith("+00:00")  # ISO 8601 UTC
        client.post("/api/queue/resume")
        e_done = ended(client, e["id"])
        assert e_done["state"] == "completed", how_it_ended(e_done)
        states = [ev["state"] for ev in client.get(f"/api/jobs/{e['id']}/events").json()]
        assert states[0] == "queued" and states[-1] == "completed" and "running" in states
        yield client, {"a": a, "c": c_end, "d": d_after, "e": e_done}


def _imported_tow(client: httpx.Client, folder: Path, mean_n: float, seed: int) -> str:
    """A tow under a force swelling about ``mean_n`` (N), imported over HTTP: its samples
    are the same however busy the host (``tests.integration.test_import_kinds``)."""
    path = folder / f"tow{seed}.csv"
    _tow_csv(path, mean_n, seed)
    r = client.post(
        "/api/runs/import",
        params={"kind": "tow", "drive_column": "pull (kgf)", "drive_unit": "kgf",
                "release_time_s": 1, "filename": path.name},
        content=path.read_bytes(),
        headers={"Content-Type": "text/csv"},
    )  # fmt: skip
    assert r.status_code == 201, r.text
    return r.json()["run_id"]


@pytest.mark.parametrize("db_url", ["postgresql"], indirect=True)
def test_queue_survives_kill_and_restart(db_url, tmp_path):
    with crashed_and_recovered(db_url, tmp_path) as (client, _):
        assert not client.get("/api/queue").json()["paused"]  # E ran: nothing left queued


@pytest.mark.parametrize("db_url", ["sqlite"], indirect=True)
def test_queue_survives_kill_and_restart_reports_survive_a_clean_stop(db_url, tmp_path):
    with crashed_and_recovered(db_url, tmp_path) as (client, jobs):
        runs = [
            _imported_tow(client, tmp_path, mean, seed) for mean, seed in ((20.0, 1), (45.0, 2))
        ]
        r = client.post("/api/jobs/estimation", json={"run_ids": runs, "method": "output-error"})
        assert r.status_code == 202, r.text
        est = ended(client, r.json()["id"], timeout_s=120)
        assert est["state"] == "completed", how_it_ended(est)
        plots = client.get(f"/api/results/{est['result_id']}").json()["report_plots"]
        assert "fit" in plots
        png = client.get(f"/api/results/{est['result_id']}/report/fit.png")
        assert png.status_code == 200 and png.content.startswith(b"\x89PNG")
        svg = client.get(f"/api/results/{est['result_id']}/report/fit.svg")
        assert svg.status_code == 200 and b"<svg" in svg.content
        # a clean stop (SIGTERM) at the end of the block

    with served(db_url, tmp_path) as (_, client):
        again = job(client, est["id"])
        assert again["state"] == "completed" and again["result_id"] == est["result_id"]
        assert again["finished_at"] == est["finished_at"]
        assert client.get(f"/api/results/{est['result_id']}").json()["report_plots"] == plots
        png_again = client.get(f"/api/results/{est['result_id']}/report/fit.png")
        assert png_again.status_code == 200 and png_again.content == png.content
        events = client.get(f"/api/jobs/{jobs['e']['id']}/events").json()
        states = [ev["state"] for ev in events]
        assert states[0] == "queued" and states[-1] == "completed" and "running" in states
        assert not client.get("/api/queue").json()["paused"]  # nothing queued: not paused
