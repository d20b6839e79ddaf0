"""The pendulum free-decay job over HTTP on the simulated rig (a fast pendulum rig file)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from api.app import create_app
from api.service import RigService
from daq.session import RigSource
from tests.api.conftest import AUTH, TOKEN, start_job, wait_job
from tests.procedures.test_pendulum import fast_rig_file


@pytest.fixture(scope="module")
def client(tmp_path_factory) -> Iterator[TestClient]:
    tmp = tmp_path_factory.mktemp("pendulum-api")
    service = RigService(RigSource.load(fast_rig_file(tmp)), f"sqlite:///{tmp / 'rig.db'}")
    app = create_app(service, token=TOKEN, report_root=tmp / "reports")
    with TestClient(app) as c:
        yield c


def test_bad_pendulum_requests_are_422_naming_the_field(client):
    for body, field, text in (
        ({"start_angle_rad": 0.9}, "start_angle_rad", "max_angle_rad"),
        ({}, "start_angle_rad", "allowed 0 < start_angle_rad ≤ 0.5 rad"),
        ({"start_angle_rad": 0.3, "stop_amplitude_rad": -1.0}, "stop_amplitude_rad", "allowed"),
    ):
        r = client.post("/api/jobs/pendulum", json=body, headers=AUTH)
        assert r.status_code == 422, r.text
        (problem,) = r.json()["errors"]
        assert problem["field"] == field and text in problem["allowed"]
    strict = client.post("/api/jobs/pendulum", json={"start_angle_rad": "0.3"}, headers=AUTH)
    assert strict.status_code == 422  # a number must be a JSON number


def test_pendulum_job_end_to_end_stores_a_completed_decay(client):
    body = {"start_angle_rad": 0.3, "stop_amplitude_rad": 0.12, "max_time_s": 15, "baseline_s": 0.3}
    job = wait_job(client, start_job(client, "/api/jobs/pendulum", body), timeout_s=40)
    assert job["state"] == "completed", job
    assert job["kind"] == "pendulum" and job["label"] == "pendulum 0.3 rad"
    (run_id,) = job["run_ids"]
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["kind"] == "pendulum" and run["status"] == "completed"
    assert run["parameters"]["stop_amplitude_rad"] == 0.12
    samples = client.get(f"/api/runs/{run_id}/samples", headers=AUTH).json()
    angle = [a for a in samples["channels"]["pendulum_angle"] if a is not None]
    assert max(angle) == pytest.approx(0.3, abs=1e-3) and min(angle) < -0.1  # it swung
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["sample"]["channels"]["pendulum_release"] == 0.0  # caught
    assert status["lock_holder"] is None
