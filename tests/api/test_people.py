"""Safety and people (issue 23): named users with roles (a viewer cannot start a test), the
user, job and sequence stored on jobs and runs, motion refused after an emergency stop
until a named operator acknowledges it (the stop itself needs no token), and a rig held
by the person at the tank refusing everyone else's start, naming who and why."""

from __future__ import annotations

import asyncio

import pytest
from click.testing import CliRunner

from api.cli.main import main
from api.core.stream import Client
from daq.store.people_and_safety_log import UserRepository
from tests.api.conftest import AUTH, SHORT_TOW, how_it_ended, wait_job, wait_rig_free
from tests.support.waiting import read_until

pytestmark = pytest.mark.simtime


@pytest.fixture(scope="module")
def tokens(service, client) -> dict[str, dict[str, str]]:
    """Authorization headers of alice and bob (operators) and vic (viewer)."""
    users = UserRepository(service.store)
    roles = {"alice": "operator", "bob": "operator", "vic": "viewer"}
    return {n: {"Authorization": f"Bearer {users.add(n, r)}"} for n, r in roles.items()}


def _tow(client, headers, **query):
    wait_rig_free(client)
    return client.post("/api/jobs/tow", json=SHORT_TOW, headers=headers, params=query)


def test_a_viewer_token_cannot_start_a_test_but_reads(client, tokens) -> None:
    r = _tow(client, tokens["vic"])
    assert r.status_code == 403, r.text
    assert r.json()["detail"].startswith("user 'vic' has role viewer")
    assert "needs role operator" in r.json()["detail"]
    assert client.get("/api/rig", headers=tokens["vic"]).status_code == 200
    assert client.get("/api/whoami", headers=tokens["vic"]).json() == {
        "name": "vic",
        "role": "viewer",
    }
    wrong = client.get("/api/rig", headers={"Authorization": "Bearer not-a-token"})
    assert wrong.status_code == 401


def test_the_user_job_and_sequence_are_stored_on_jobs_and_runs(client, service, tokens) -> None:
    r = _tow(client, tokens["alice"])
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"])
    assert job["state"] == "completed" and job["user"] == "alice"
    stored = client.app.state.runner.repo.get(job["id"])
    assert stored["user_name"] == "alice"  # in the database, not only in memory
    run = service.store.get_run(job["run_ids"][0])
    assert run.metadata["started_by"] == "alice" and run.metadata["job_id"] == job["id"]

    wait_rig_free(client)
    body = {"name": "one step", "steps": [{"kind": "tow", **SHORT_TOW}]}
    r = client.post("/api/jobs/sequence", json=body, headers=tokens["bob"])
    assert r.status_code == 202, r.text
    seq = wait_job(client, r.json()["id"])
    assert seq["state"] == "completed" and seq["user"] == "bob"
    meta = service.store.get_run(seq["run_ids"][0]).metadata
    origin = ("bob", seq["id"], "one step", 1)
    assert (meta["started_by"], meta["job_id"], meta["sequence"], meta["sequence_step"]) == origin

    fit = client.post(
        "/api/jobs/estimation", json={"run_ids": job["run_ids"]}, headers=tokens["bob"]
    )
    assert fit.status_code == 202 and fit.json()["user"] == "bob", fit.text  # every job


def test_motion_is_refused_after_an_emergency_stop_until_acknowledged(client, tokens) -> None:
    stop = client.post("/api/rig/emergency-stop")  # no token at all
    assert stop.status_code == 200, stop.text
    assert client.get("/api/rig", headers=AUTH).json()["guard"]["estop"]["by"] is None

    refused = _tow(client, AUTH)
    assert refused.status_code == 409, refused.text
    assert "emergency stop" in refused.json()["detail"]
    assert "not acknowledged" in refused.json()["detail"]
    assert client.post("/api/rig/arm", headers=AUTH).status_code == 409
    assert client.post("/api/estop/ack", headers=tokens["vic"]).status_code == 403

    ack = client.post("/api/estop/ack", json={"note": "tank clear"}, headers=tokens["alice"])
    assert ack.status_code == 200 and ack.json()["estop"] is None, ack.text
    events = client.get("/api/rig/events", headers=AUTH).json()
    assert [(e["kind"], e["user"]) for e in events[:2]] == [("estop_ack", "alice"), ("estop", None)]
    assert "tank clear" in events[0]["message"]
    again = client.post("/api/estop/ack", headers=tokens["alice"])
    assert again.status_code == 409  # nothing left to acknowledge

    moved = _tow(client, AUTH)
    assert moved.status_code == 202, moved.text
    job_end = wait_job(client, moved.json()["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)


def test_each_guard_change_through_the_service_is_published_on_its_stream(
    client, service, tokens
) -> None:
    """A stop, its acknowledgement, a hold and its release each send the guard's new state
    to every stream client (a ``guard`` event), so an open page shows a stop pressed
    elsewhere at once, not at its next poll (tests/api/test_estop_browser.py)."""
    loop = asyncio.new_event_loop()  # the listener's wake-ups go there; nothing runs it
    listener = Client(loop, None, samples=False, jobs=False)
    service.broadcaster.add(listener)
    try:
        assert client.post("/api/rig/emergency-stop").status_code == 200
        assert client.post("/api/estop/ack", headers=tokens["alice"]).status_code == 200
        hold = {"reason": "rigging the vehicle"}
        assert client.post("/api/rig/hold", json=hold, headers=tokens["alice"]).status_code == 200
        assert client.post("/api/rig/release", headers=tokens["alice"]).status_code == 200
    finally:
        service.broadcaster.remove(listener)
        loop.close()
    assert {kind for kind, _ in listener.queue} == {"guard"}
    shown = [
        (guard["estop"] is not None, guard["hold"] and guard["hold"]["by"])
        for _, guard in listener.queue
    ]
    assert shown == [(True, None), (False, None), (False, "alice"), (False, None)]
    stop = listener.queue[0][1]["estop"]  # as GET /api/rig → guard shows it
    assert stop["by"] is None and "emergency stop" in stop["message"] and stop["at"]


def test_a_held_rig_refuses_a_remote_start_naming_who_holds_it(client, tokens) -> None:
    held = client.post(
        "/api/rig/hold", json={"reason": "rigging the vehicle"}, headers=tokens["alice"]
    )
    assert held.status_code == 200 and held.json()["hold"]["by"] == "alice", held.text

    refused = _tow(client, tokens["bob"])
    assert refused.status_code == 423, refused.text
    assert refused.json()["holder"] == "alice"
    assert "held by alice" in refused.json()["detail"]
    assert "rigging the vehicle" in refused.json()["detail"]
    assert _tow(client, AUTH).status_code == 423  # the service token is someone else too
    assert client.post("/api/rig/release", headers=tokens["bob"]).status_code == 423

    own = _tow(client, tokens["alice"])  # the holder starts her own test
    assert own.status_code == 202, own.text
    job_end = wait_job(client, own.json()["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)

    override = client.post("/api/rig/release", json={"override": True}, headers=tokens["bob"])
    assert override.status_code == 200 and override.json()["hold"] is None
    last = client.get("/api/rig/events", headers=AUTH).json()[0]
    assert last["user"] == "bob" and "override" in last["message"] and "alice" in last["message"]


def test_a_hold_taken_with_the_cli_reaches_the_running_service(client, service, tokens) -> None:
    cli = CliRunner()
    db = ["--db", service.store.url]
    taken = cli.invoke(main, ["hold", "--user", "alice", "--reason", "at the tank", *db])
    assert taken.exit_code == 0, taken.output
    refused = _tow(client, tokens["bob"], queue="false")
    assert refused.status_code == 423 and "at the tank" in refused.json()["detail"]
    freed = cli.invoke(main, ["release", "--user", "alice", *db])
    assert freed.exit_code == 0, freed.output
    assert client.get("/api/rig", headers=AUTH).json()["guard"]["hold"] is None


def test_a_queued_job_of_another_user_waits_while_the_rig_is_held(client, tokens) -> None:
    """Queued before the hold: when the rig frees, the queue pauses naming the holder
    instead of starting it; after the release, resuming runs it."""
    wait_rig_free(client)
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]  # e-stop's
    first = client.post("/api/jobs/tow", json=SHORT_TOW, headers=tokens["bob"]).json()
    queued = client.post("/api/jobs/tow", json=SHORT_TOW, headers=tokens["bob"]).json()
    assert queued["state"] == "queued", queued
    held = client.post("/api/rig/hold", json={"reason": "fins"}, headers=tokens["alice"])
    assert held.status_code == 200, held.text
    job_end = wait_job(client, first["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)
    queue = read_until(
        lambda: client.get("/api/queue", headers=AUTH).json(),
        lambda q: q["paused"],
        "the queue paused by the hold",
    )
    assert "held by alice" in queue["reason"] and "fins" in queue["reason"]
    assert client.get(f"/api/jobs/{queued['id']}", headers=AUTH).json()["state"] == "queued"
    client.post("/api/rig/release", headers=tokens["alice"])
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]
    job_end = wait_job(client, queued["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)


def test_the_command_line_refuses_a_test_after_an_unacknowledged_stop(tmp_path) -> None:
    from daq.store import Store
    from daq.store.people_and_safety_log import ESTOP, RigEventLog

    db = f"sqlite:///{tmp_path}/rig.db"
    with Store(db) as store:
        RigEventLog(store, "BENBAM tow tank").add(ESTOP, None, "emergency stop (API)")
    ran = CliRunner().invoke(main, ["tow", "--force", "10", "--db", db])
    assert ran.exit_code == 1, ran.output
    assert "emergency stop" in ran.output and "rig ack-estop" in ran.output
    with Store(db) as store:
        assert store.list_runs() == []  # nothing recorded, nothing moved


def test_a_stop_the_log_cannot_record_still_refuses_motion(client, tokens, monkeypatch) -> None:
    """The stop never waits for the database; if the safety log refuses the write, motion
    stays refused (from memory) until an operator acknowledges."""
    from daq.store.people_and_safety_log import ESTOP, RigEventLog

    written = RigEventLog.add

    def full_disk(self, kind, user_name, message):
        if kind == ESTOP:
            raise OSError("database or disk is full")
        return written(self, kind, user_name, message)

    monkeypatch.setattr(RigEventLog, "add", full_disk)
    assert client.post("/api/rig/emergency-stop").status_code == 200
    refused = _tow(client, AUTH)
    assert refused.status_code == 409 and "could not be" in refused.json()["detail"]
    ack = client.post("/api/estop/ack", headers=tokens["alice"])
    assert ack.status_code == 200, ack.text
    assert client.get("/api/rig/events", headers=AUTH).json()[0]["user"] == "alice"
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]
    moved = _tow(client, AUTH)
    assert moved.status_code == 202, moved.text
    wait_job(client, moved.json()["id"])
