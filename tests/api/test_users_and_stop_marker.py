"""Queue leftovers of issue 23: user management over HTTP (admin = the service token) and a
stop marker in the queue (the queue pauses when it reaches it, bluesky-queueserver's
``queue_stop``)."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, SHORT_TOW, how_it_ended, wait_job, wait_rig_free

pytestmark = pytest.mark.simtime


def _bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def test_admin_adds_lists_rotates_and_removes_a_user(client) -> None:
    r = client.post("/api/users", json={"name": "olga", "role": "operator"}, headers=AUTH)
    assert r.status_code == 201, r.text
    olga = r.json()["token"]
    assert client.get("/api/whoami", headers=_bearer(olga)).json()["name"] == "olga"
    names = [u["name"] for u in client.get("/api/users", headers=AUTH).json()]
    assert "olga" in names
    assert all("token" not in u for u in client.get("/api/users", headers=AUTH).json())
    # a named operator is not the admin: no user management
    denied = client.post(
        "/api/users", json={"name": "eve", "role": "operator"}, headers=_bearer(olga)
    )
    assert denied.status_code == 403 and "service token" in denied.json()["detail"]
    assert client.get("/api/users", headers=_bearer(olga)).status_code == 403
    # rotate: the old token stops working at once, the new one works
    r = client.post("/api/users/olga/token", headers=AUTH)
    assert r.status_code == 200, r.text
    new = r.json()["token"]
    assert new != olga
    assert client.get("/api/whoami", headers=_bearer(olga)).status_code == 401
    assert client.get("/api/whoami", headers=_bearer(new)).json()["role"] == "operator"
    # add again: 409; bad name: 422 naming the field; remove: 204, then 404
    again = client.post("/api/users", json={"name": "olga"}, headers=AUTH)
    assert again.status_code == 409
    bad = client.post("/api/users", json={"name": "9lives"}, headers=AUTH)
    assert bad.status_code == 422 and "name" in bad.text
    assert client.delete("/api/users/olga", headers=AUTH).status_code == 204
    assert client.get("/api/whoami", headers=_bearer(new)).status_code == 401
    assert client.delete("/api/users/olga", headers=AUTH).status_code == 404
    assert client.post("/api/users/olga/token", headers=AUTH).status_code == 404


def test_the_queue_stops_at_a_stop_marker_and_resumes_past_it(client) -> None:
    wait_rig_free(client)
    client.post("/api/queue/pause", headers=AUTH)
    first = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH).json()
    r = client.post("/api/queue/stop-marker", json={}, headers=AUTH)
    assert r.status_code == 201, r.text
    second = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH).json()
    queue = client.get("/api/queue", headers=AUTH).json()
    kinds = [j["kind"] for j in queue["jobs"]]
    assert kinds == ["tow", "queue_stop", "tow"], queue
    marker = queue["jobs"][1]
    assert marker["position"] == 2 and marker["user"] == "default"

    client.post("/api/queue/resume", headers=AUTH)
    job_end = wait_job(client, first["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)
    done = wait_job(client, marker["id"])
    assert done["state"] == "completed" and done["progress"]["message"] == "stop marker reached"
    queue = client.get("/api/queue", headers=AUTH).json()
    assert queue["paused"] and "stop marker placed by default" in queue["reason"]
    assert [j["id"] for j in queue["jobs"]] == [second["id"]]  # waits behind the marker
    assert client.get(f"/api/jobs/{second['id']}", headers=AUTH).json()["state"] == "queued"

    client.post("/api/queue/resume", headers=AUTH)
    job_end = wait_job(client, second["id"])
    assert job_end["state"] == "completed", how_it_ended(job_end)


def test_a_stop_marker_outside_the_queue_is_refused_naming_the_position(client) -> None:
    r = client.post("/api/queue/stop-marker", json={"position": 9}, headers=AUTH)
    assert r.status_code == 422 and "position" in r.text
