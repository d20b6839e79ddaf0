"""Editing the queue over HTTP, as the Queue page does: a paused queue holds new jobs
without moving the rig; a queued job's parameters are replaced (validated like a new
submission) in place; a job is run now; "stop after the current job" lets the running job
finish and starts no other; a past job is re-queued; sequence files are listed with their
steps and start as a sequence job."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, SHORT_TOW, how_it_ended, wait_job, wait_rig_free

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py): the
#: queue's edits are what is tested, not the rig's timing, and in real time a spin on a loaded
#: test process lost samples to its own late simulated PLC and ended aborted.
pytestmark = pytest.mark.simtime


def _queue(client) -> dict:
    return client.get("/api/queue", headers=AUTH).json()


def _post(client, path: str, body: dict) -> dict:
    r = client.post(path, json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    return r.json()


def test_a_paused_queue_holds_new_jobs_which_are_edited_run_now_and_requeued(client):
    wait_rig_free(client)
    paused = client.post("/api/queue/pause", headers=AUTH).json()
    assert paused["paused"] and "stopped by the operator" in paused["reason"], paused

    tow = _post(client, "/api/jobs/tow", SHORT_TOW)
    spin = _post(client, "/api/jobs/spin", {"torque_nm": 0.454, "max_time_s": 3.0})
    assert (tow["state"], tow["position"]) == ("queued", 1)  # held: the rig did not move
    assert (spin["state"], spin["position"]) == ("queued", 2)
    assert client.get("/api/rig", headers=AUTH).json()["current_job"] is None
    assert tow["request"] == SHORT_TOW | {"drive": "weight"}  # as validated
    shown = {p["key"]: p["shown"] for p in tow["parameters_labelled"]}
    assert shown["force_n"].endswith(" N") and shown["max_time_s"] == "1.5 s", shown
    refused = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH, params={"queue": "false"})
    assert refused.status_code == 409 and "paused" in refused.json()["detail"], refused.text

    # Replace the tow's parameters: validated like a new tow, kept in its place.
    replaced = client.put(
        f"/api/queue/{tow['id']}", json=SHORT_TOW | {"force_n": 44.1}, headers=AUTH
    )
    assert replaced.status_code == 200, replaced.text
    assert replaced.json()["parameters"]["force_n"] != tow["parameters"]["force_n"]
    assert "44" in replaced.json()["label"] and replaced.json()["position"] == 1
    for bad, field in (
        ({"force_n": 500.0}, "force_n"),  # over the rig's max_force_n
        ({"force_n": "44"}, "force_n"),  # a string where a number belongs
        ({"force_n": 44.1, "colour": "red"}, "colour"),  # not a tow's field
        ({"torque_nm": 0.4}, "torque_nm"),  # a spin's field on a tow
    ):
        r = client.put(f"/api/queue/{tow['id']}", json=bad, headers=AUTH)
        assert r.status_code == 422, (bad, r.text)
        assert any(field in e["field"] for e in r.json()["errors"]), (bad, r.json())
    after = client.get(f"/api/jobs/{tow['id']}", headers=AUTH).json()
    assert after["parameters"] == replaced.json()["parameters"]  # a refused edit changes nothing
    assert client.put("/api/queue/nosuchjob", json=SHORT_TOW, headers=AUTH).status_code == 404

    # Run the spin now: first in the queue, the queue resumed, on the rig at once.
    now = client.post(f"/api/queue/{spin['id']}/run-now", headers=AUTH).json()
    assert not now["paused"] and now["running"]["id"] == spin["id"], now
    assert [j["id"] for j in now["jobs"]] == [tow["id"]]
    # Stop after the current job: the spin finishes, the tow waits.
    stop = client.post("/api/queue/pause", headers=AUTH).json()
    assert stop["paused"] and stop["running"]["id"] == spin["id"]
    on_rig = client.put(f"/api/queue/{spin['id']}", json={"torque_nm": 0.3}, headers=AUTH)
    assert on_rig.status_code == 409, on_rig.text
    ended = wait_job(client, spin["id"])
    assert ended["state"] == "completed", how_it_ended(ended)
    wait_rig_free(client)
    queue = _queue(client)
    assert queue["paused"] and [j["id"] for j in queue["jobs"]] == [tow["id"]], queue
    assert client.get(f"/api/jobs/{tow['id']}", headers=AUTH).json()["state"] == "queued"

    # Re-queue the finished spin: a new job with the same request, behind the tow.
    again = client.post(f"/api/jobs/{spin['id']}/requeue", headers=AUTH)
    assert again.status_code == 202, again.text
    assert again.json()["id"] != spin["id"] and again.json()["request"] == spin["request"]
    assert again.json()["position"] == 2
    assert client.post(f"/api/jobs/{tow['id']}/requeue", headers=AUTH).status_code == 409
    for job_id in (tow["id"], again.json()["id"]):
        assert client.delete(f"/api/queue/{job_id}", headers=AUTH).status_code == 200
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]


def test_sequence_files_are_listed_with_steps_and_start_as_a_sequence_job(client):
    listed = client.get("/api/sequences", headers=AUTH)
    assert listed.status_code == 200, listed.text
    seed = next(s for s in listed.json() if s["file"] == "seed000-campaign")
    assert seed["problems"] == [] and seed["runs"] == len(seed["steps"]) == 8
    first = seed["steps"][0]
    assert first["kind"] == "tow" and first["parameters_labelled"][0]["shown"] == "4.9 N"
    wait_rig_free(client)
    client.post("/api/queue/pause", headers=AUTH)  # held in the queue: nothing moves
    try:
        job = _post(client, "/api/jobs/sequence", seed["content"])
        assert job["kind"] == "sequence" and job["state"] == "queued", job
        steps = [p for p in job["parameters_labelled"] if p["key"].startswith("steps[")]
        assert len(steps) == 8 and steps[0]["shown"].startswith("tow: force 4.9 N"), steps
        assert client.delete(f"/api/queue/{job['id']}", headers=AUTH).status_code == 200
    finally:
        client.post("/api/queue/resume", headers=AUTH)


def test_the_new_queue_routes_need_the_token(client):
    for method, path in (
        ("put", "/api/queue/abc"),
        ("post", "/api/queue/abc/run-now"),
        ("post", "/api/jobs/abc/requeue"),
        ("get", "/api/sequences"),
    ):
        kwargs = {"json": SHORT_TOW} if method == "put" else {}
        r = getattr(client, method)(path, **kwargs)
        assert r.status_code == 401, (method, path, r.text)
