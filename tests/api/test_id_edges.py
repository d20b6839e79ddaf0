"""Ids no resource can have (malformed, out of 64-bit range) answer 404 like unknown ones
on every route that takes an id; a body that is not JSON says so; no database URL or
internal path leaks into a message; a load rounded to a whole-gram weight is stated."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, how_it_ended, start_job, wait_job

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime

HUGE = "9" * 23
RUN_ROUTES = ("/api/runs/{}", "/api/runs/{}/samples", "/api/runs/{}/samples.csv",
              "/api/runs/{}/export", "/api/runs/{}/events", "/api/runs/{}/results")  # fmt: skip
RESULT_ROUTES = ("/api/results/{}", "/api/results/{}/report/fit.png")
JOB_ROUTES = ("/api/jobs/{}",)
JOB_ACTIONS = ("abort", "pause", "resume", "confirm")
BAD_RUN_IDS = ("zzz", "a" * 100, "tow%25", "0123abcd", "-1", HUGE)
BAD_NUMBER_IDS = (HUGE, "abc", "-1", "0", "1e3", str(2**63))


def _no_leak(detail: str) -> None:
    for leak in ("sqlite", "Store(", "/tmp/", "site-packages", "Traceback"):
        assert leak not in detail, detail


def _not_found(client, path: str, says: str) -> str:
    """GET ``path`` is a 404 whose detail begins with ``says``; the detail."""
    r = client.get(path, headers=AUTH)
    assert r.status_code == 404, r.text
    assert r.json()["detail"].startswith(says), r.text
    return r.json()["detail"]


@pytest.mark.parametrize("route", RUN_ROUTES)
@pytest.mark.parametrize("run_id", BAD_RUN_IDS)
def test_malformed_unknown_and_huge_run_ids_are_404(client, route, run_id):
    _no_leak(_not_found(client, route.format(run_id), "no run with id"))


@pytest.mark.parametrize("route", RESULT_ROUTES)
@pytest.mark.parametrize("result_id", BAD_NUMBER_IDS)
def test_malformed_and_out_of_range_result_ids_are_404(client, route, result_id):
    _not_found(client, route.format(result_id), "no result with id")


@pytest.mark.parametrize("job_id", ("nope", "a" * 300, HUGE))
def test_unknown_job_ids_are_404_on_every_job_route(client, job_id):
    assert client.get(f"/api/jobs/{job_id}", headers=AUTH).status_code == 404
    for action in JOB_ACTIONS:
        r = client.post(f"/api/jobs/{job_id}/{action}", headers=AUTH)
        assert r.status_code == 404, (action, r.text)


def test_malformed_run_ids_in_an_estimation_body_are_404(client):
    r = client.post("/api/jobs/estimation", json={"run_ids": ["zzz"]}, headers=AUTH)
    assert r.status_code == 404, r.text
    assert "no run with id 'zzz'" in r.json()["detail"]


def test_unknown_vehicle_names_are_404(client):
    r = client.get("/api/vehicles/" + "x" * 200, headers=AUTH)
    assert r.status_code == 404, r.text


@pytest.mark.parametrize(
    ("body", "says"),
    [
        (b"{", "Expecting property name enclosed in double quotes"),
        (b"{'force_n': 10}", "Expecting property name"),
        (b'{"force_n": 10,}', "at character 15"),
        (b"force_n=10", "Expecting value"),
    ],
)
def test_a_body_that_is_not_json_is_a_clear_422(client, body, says):
    r = client.post(
        "/api/jobs/tow", content=body, headers=AUTH | {"Content-Type": "application/json"}
    )
    assert r.status_code == 422, r.text
    detail = r.json()["detail"]
    assert detail.startswith("request body is not valid JSON: "), detail
    assert says in detail
    assert r.json()["errors"] == [
        {"field": "body", "value": None, "allowed": "a JSON document", "message": detail}
    ]


def test_a_rounded_load_is_stated_in_the_job_and_stored_with_the_run(client):
    job_id = start_job(
        client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 1.5, "baseline_s": 0.3}
    )
    started = client.get(f"/api/jobs/{job_id}", headers=AUTH).json()
    (note,) = started["notes"]
    assert "force_n 10 N asked for" in note and "1.020 kg" in note and "9.996 N" in note
    job = wait_job(client, job_id)
    assert job["state"] == "completed", how_it_ended(job)
    run = client.get(f"/api/runs/{job['run_ids'][0]}", headers=AUTH).json()
    assert run["parameters"]["requested"] == {"force_n": 10.0}
    assert run["parameters"]["force_n"] == pytest.approx(1.020 * 9.8)
    assert run["parameters"]["hung_mass_kg"] == pytest.approx(1.020)


def test_a_whole_gram_load_has_no_note(client):
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 9.8, "max_time_s": 1.0})
    assert client.get(f"/api/jobs/{job_id}", headers=AUTH).json()["notes"] == []
    job = wait_job(client, job_id)
    run = client.get(f"/api/runs/{job['run_ids'][0]}", headers=AUTH).json()
    assert run["parameters"]["requested"] is None
