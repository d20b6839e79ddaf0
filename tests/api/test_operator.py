"""A rig that asks a person: the job waits in ``waiting_for_operator`` until confirmed."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient

from api.http.app import create_app
from daq.session import RigSource
from tests.api.conftest import (
    AUTH,
    TOKEN,
    how_it_ended,
    moving_for,
    simulated_service,
    wait_job,
    wait_job_until,
)
from tests.support.waiting import read_until


@pytest.fixture(scope="module")
def asking_client(tmp_path_factory):
    db = tmp_path_factory.mktemp("op") / "rig.db"
    service = simulated_service(RigSource.load(), f"sqlite:///{db}", ask_operator=True)
    with TestClient(create_app(service, token=TOKEN)) as c:
        yield c


def test_operator_acts_wait_for_confirm_then_abort_ends_the_job(asking_client):
    c = asking_client
    job_id = c.post("/api/jobs/tow", json={"weight_kg": 0.5, "max_time_s": 1}, headers=AUTH).json()[
        "id"
    ]
    first = wait_job(c, job_id, states=("waiting_for_operator",))
    assert first["operator_act"]["name"] == "return_carriage"
    assert "Return the carriage" in first["progress"]["message"]
    assert c.post(f"/api/jobs/{job_id}/confirm", headers=AUTH).status_code == 200

    second = read_until(  # the confirm wakes the procedure, which then asks for the weight
        lambda: c.get(f"/api/jobs/{job_id}", headers=AUTH).json(),
        lambda job: (job["operator_act"] or {}).get("name", "return_carriage") != "return_carriage",
        "the next operator act after the confirm",
        timeout_s=10,
        poll_s=0.02,
    )
    assert second["state"] == "waiting_for_operator"
    assert second["operator_act"]["name"] == "hang_tow_weight"
    assert second["operator_act"]["value"] == pytest.approx(0.5)
    assert "Hang 0.500 kg" in second["operator_act"]["instruction"]
    assert c.post(f"/api/jobs/{job_id}/abort", headers=AUTH).status_code == 200
    done = wait_job(c, job_id)
    assert done["state"] == "aborted"
    assert done["operator_act"] is None
    assert c.get("/api/rig", headers=AUTH).json()["lock_holder"] is None


def test_stopping_the_service_aborts_the_running_test_and_records_why(tmp_path):
    from daq.store import Store

    url = f"sqlite:///{tmp_path / 'rig.db'}"
    service = simulated_service(RigSource.load(), url)
    with TestClient(create_app(service, token=TOKEN)) as c:
        body = {"force_n": 10.0, "max_time_s": 60, "baseline_s": 0.2}
        job_id = c.post("/api/jobs/tow", json=body, headers=AUTH).json()["id"]
        run_ids = wait_job_until(c, job_id, moving_for(0.2), "recording under way")["run_ids"]
    with Store(url) as store:
        run = store.get_run(run_ids[0])
        assert run.status == "aborted"
        assert run.reason == "service stopped"
        assert run.sample_count >= 3  # what was recorded before the stop is kept


def test_a_reverse_tow_asks_for_the_far_end_pulley_and_says_reverse(asking_client):
    c = asking_client
    body = {"weight_kg": -0.5, "max_time_s": 1}
    job_id = c.post("/api/jobs/tow", json=body, headers=AUTH).json()["id"]
    try:
        first = wait_job(c, job_id, states=("waiting_for_operator",))
        assert first["operator_act"]["name"] == "return_carriage"
        assert first["operator_act"]["reverse"] is True
        assert "far end of the rail" in first["operator_act"]["instruction"]
        assert c.post(f"/api/jobs/{job_id}/confirm", headers=AUTH).status_code == 200
        hang = wait_job_until(
            c,
            job_id,
            lambda job: (job["operator_act"] or {}).get("name") == "hang_tow_weight",
            "the ask for the weight",
        )
        assert hang["operator_act"]["reverse"] is True
        assert "far-end pulley" in hang["operator_act"]["instruction"]
        assert hang["operator_act"]["value"] == pytest.approx(0.5)
    finally:
        c.post(f"/api/jobs/{job_id}/abort", headers=AUTH)
        job_end = wait_job(c, job_id)
        assert job_end["state"] == "aborted", how_it_ended(job_end)
