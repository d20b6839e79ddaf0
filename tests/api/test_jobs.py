"""Procedures as jobs on the simulated rig: tow end to end, 409 with ``?queue=false``,
abort, e-stop (which pauses the queue), sequences. The rig runs in process on simulated
time (paced, tests/api/conftest.py)."""

from __future__ import annotations

import time

import pytest

from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    how_it_ended,
    moving_for,
    start_job,
    wait_job,
    wait_job_until,
    wait_rig_free,
)
from tests.support.waiting import read_until

pytestmark = pytest.mark.simtime


def test_tow_job_end_to_end_stores_a_completed_run(client, tow_job):
    assert tow_job["kind"] == "tow"
    assert tow_job["progress"]["fraction"] == 1.0
    (run_id,) = tow_job["run_ids"]
    assert tow_job["outcome"]["run_id"] == run_id
    assert tow_job["outcome"]["status"] == "completed"
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["status"] == "completed"
    assert run["kind"] == "tow"
    assert run["parameters"]["force_n"] == 24.5
    # ~0.3 s baseline + 1.5 s released + tail at 10 Hz
    assert 15 <= run["sample_count"] <= 40
    samples = client.get(f"/api/runs/{run_id}/samples", headers=AUTH).json()
    position = [p for p in samples["channels"]["tow_position"] if p is not None]
    assert max(position) - min(position) > 0.05, "the carriage moved under 24.5 N"


def test_second_start_while_busy_without_queueing_is_409_naming_the_holder(client):
    job_id = start_job(client, "/api/jobs/tow", SHORT_TOW)
    try:
        for path, body in (
            ("/api/jobs/tow", {"force_n": 4.9}),
            ("/api/jobs/spin", {"torque_nm": 0.454}),
            ("/api/jobs/calibration", {}),
        ):
            busy = client.post(path, json=body, headers=AUTH, params={"queue": "false"})
            assert busy.status_code == 409, busy.text
            assert busy.json()["holder"] == f"tow 24.5 N (job {job_id})"
            assert "busy" in busy.json()["detail"]
        assert client.post("/api/rig/arm", headers=AUTH).status_code == 409
        status = client.get("/api/rig", headers=AUTH).json()
        assert status["current_job"]["id"] == job_id
    finally:
        client.post(f"/api/jobs/{job_id}/abort", headers=AUTH)
        wait_job(client, job_id)


def test_abort_ends_the_run_aborted_with_brake_on(client):
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
    wait_job_until(client, job_id, moving_for(0.3), "the carriage moving")
    r = client.post(f"/api/jobs/{job_id}/abort", headers=AUTH)
    assert r.status_code == 200
    job = wait_job(client, job_id, timeout_s=10)
    assert job["state"] == "aborted"
    assert "operator abort" in job["progress"]["message"]
    run = client.get(f"/api/runs/{job['run_ids'][0]}", headers=AUTH).json()
    assert run["status"] == "aborted"
    assert "operator abort" in run["reason"]
    # brake engaged: the first sample read after the job ended shows the coil off
    ended_seq = client.get("/api/rig", headers=AUTH).json()["sample"]["seq"]
    status = read_until(
        lambda: client.get("/api/rig", headers=AUTH).json(),
        lambda status: status["sample"]["seq"] > ended_seq,
        "a sample after the abort",
        timeout_s=5.0,
        poll_s=0.02,
    )
    assert status["sample"]["channels"]["tow_release"] == 0.0
    assert status["lock_holder"] is None
    # an ended job cannot be aborted again
    assert client.post(f"/api/jobs/{job_id}/abort", headers=AUTH).status_code == 409


def test_emergency_stop_aborts_the_running_job(client):
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
    wait_job(client, job_id, states=("running",))
    stop = client.post("/api/rig/emergency-stop", headers=AUTH)
    assert stop.status_code == 200
    assert stop.json() == {"aborted_jobs": [job_id], "safe_state": True}
    job = wait_job(client, job_id, timeout_s=10)
    assert job["state"] == "aborted"
    assert "emergency stop" in (job["error"] or job["progress"]["message"])
    assert client.post("/api/estop/ack", headers=AUTH).status_code == 200  # motion again


def test_emergency_stop_pauses_the_queue_and_keeps_its_jobs(client):
    running = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
    wait_job(client, running, states=("running",))
    queued = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH).json()
    assert (queued["state"], queued["position"]) == ("queued", 1)
    stop = client.post("/api/rig/emergency-stop", headers=AUTH).json()
    assert stop["aborted_jobs"] == [running]
    job_end = wait_job(client, running, timeout_s=10)
    assert job_end["state"] == "aborted", how_it_ended(job_end)
    queue = client.get("/api/queue", headers=AUTH).json()
    assert queue["paused"] and "emergency stop" in queue["reason"], queue
    assert [j["id"] for j in queue["jobs"]] == [queued["id"]]  # kept, not started
    assert client.get(f"/api/jobs/{queued['id']}", headers=AUTH).json()["state"] == "queued"
    assert client.delete(f"/api/queue/{queued['id']}", headers=AUTH).json()["jobs"] == []
    assert client.post("/api/estop/ack", headers=AUTH).status_code == 200
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]


def test_the_queue_is_bounded_a_start_beyond_it_is_409(client, monkeypatch):
    monkeypatch.setattr("api.core.job_queue.MAX_QUEUED", 2)
    running = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
    wait_job(client, running, states=("running",))
    queued = [client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH) for _ in range(3)]
    assert [r.status_code for r in queued] == [202, 202, 409]
    assert "queue is full" in queued[2].json()["detail"], queued[2].text
    assert len(client.get("/api/queue", headers=AUTH).json()["jobs"]) == 2
    client.post("/api/rig/emergency-stop", headers=AUTH)
    for r in queued[:2]:
        client.delete(f"/api/queue/{r.json()['id']}", headers=AUTH)
    assert client.post("/api/estop/ack", headers=AUTH).status_code == 200  # motion again
    assert not client.post("/api/queue/resume", headers=AUTH).json()["paused"]


def test_arm_and_disarm_thrusters(client):
    wait_rig_free(client)
    r = client.post("/api/rig/arm", headers=AUTH)
    assert r.status_code == 200, r.text
    assert r.json()["armed"] is True
    assert r.json()["thrusters"]["state"] == "ARMED"
    r = client.post("/api/rig/disarm", headers=AUTH)
    assert r.json()["armed"] is False
    assert r.json()["thrusters"]["state"] == "DISARMED"


def test_arming_a_controller_that_does_not_answer_is_a_503_naming_it(client, service):
    """The simulated thruster controller falls silent: arming is refused in one line naming
    the controller (a documented 503, not a 500 with a traceback) and the rig stays
    disarmed; once it answers again, arming works."""
    wait_rig_free(client)
    emulator = service.session.sim.thrusters
    emulator.silent = True  # it hears nothing and says nothing
    try:
        r = client.post("/api/rig/arm", headers=AUTH)
    finally:
        emulator.silent = False
    assert r.status_code == 503, r.text
    assert r.json()["detail"].startswith("thrusters: arm: controller at ")
    assert "gave no reply" in r.json()["detail"]
    assert client.get("/api/rig", headers=AUTH).json()["armed"] is False
    assert client.post("/api/rig/arm", headers=AUTH).status_code == 200
    assert client.post("/api/rig/disarm", headers=AUTH).json()["armed"] is False


def test_rig_status_reports_values_clock_and_limits(client):
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["running"] and status["connected"] and status["simulated"]
    assert status["device_lost"] is False
    assert set(status["sample"]["channels"]) >= {"tow_position", "yaw_angle", "load_cell"}
    assert status["clock"]["rate_hz"] == 10.0
    assert status["clock"]["ticks"] > 0
    clock = status["clock"]  # the overruns, and of them those the host made
    assert 0 <= clock["late_wakeups"] + clock["host_stalls"] <= clock["overruns"]
    assert 0 <= status["clock"]["lateness_p50_s"] <= status["clock"]["lateness_p99_s"]
    assert status["limits"]["max_force_n"] == 100.0


def test_sequence_pauses_between_steps_and_resumes(client):
    # a first step long enough to be seen running (3 s simulated, 0.3 s at the service's pace)
    step = {"kind": "tow", "force_n": 4.9, "max_time_s": 3.0, "baseline_s": 0.0}
    body = {"name": "api test", "rest_s": 0.2, "steps": [step, step]}
    job_id = start_job(client, "/api/jobs/sequence", body)
    # paused while its first step runs (a pause that lands before it starts holds it there)
    wait_job_until(
        client,
        job_id,
        lambda job: (job.get("progress") or {}).get("message", "").startswith("step 1/2"),
        "the first step running",
    )
    assert client.post(f"/api/jobs/{job_id}/pause", headers=AUTH).status_code == 200
    paused = wait_job(client, job_id, states=("paused", *("completed", "aborted", "failed")))
    assert paused["state"] == "paused", paused
    assert len(paused["run_ids"]) == 1  # the first step finished, the second waits
    time.sleep(0.4)  # observation window, twice the 0.2 s rest: the pause must hold through it
    assert client.get(f"/api/jobs/{job_id}", headers=AUTH).json()["state"] == "paused"
    assert client.post(f"/api/jobs/{job_id}/resume", headers=AUTH).status_code == 200
    done = wait_job(client, job_id)
    assert done["state"] == "completed", how_it_ended(done)
    assert len(done["run_ids"]) == 2
    assert [r["status"] for r in done["outcome"]["runs"]] == ["completed", "completed"]


def test_pause_and_confirm_refused_when_they_do_not_apply(client, tow_job):
    for action in ("pause", "resume", "confirm"):
        r = client.post(f"/api/jobs/{tow_job['id']}/{action}", headers=AUTH)
        assert r.status_code == 409, (action, r.text)
