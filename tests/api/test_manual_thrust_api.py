"""The thrust stand over the API, on the simulated rig in process (simulated time): the live
stream carries each thruster's RPM and current with the supply voltage during a calibration;
one thruster under manual control is a run of its own kind, refused for a viewer, while
disarmed and beyond the rig's limits, and a dead-man — back to zero with the brake engaged
when its time is up, when its page falls silent and on an emergency stop."""

from __future__ import annotations

import asyncio
import json

import numpy as np
import pytest

from api.core.stream import sse_events
from daq.store.people_and_safety_log import UserRepository
from daq.store.run_events import RunAction
from tests.api.conftest import (
    AUTH,
    how_it_ended,
    start_job,
    wait_job,
    wait_job_until,
    wait_rig_free,
)
from tests.procedures.conftest import QUICK_CALIBRATION
from tests.support.waiting import read_until

pytestmark = pytest.mark.simtime

MANUAL = "/api/jobs/manual-thrust"


def _arm(client) -> None:
    wait_rig_free(client)
    r = client.post("/api/rig/arm", headers=AUTH)
    assert r.status_code == 200 and r.json()["armed"], r.text


def _thrust_on(client, job_id: str, thruster: int) -> dict:
    """The rig's status once the manual run's thruster is commanded (its ramp under way)."""
    wait_job_until(client, job_id, lambda j: "s left" in j["progress"]["message"], "thrust on")
    return read_until(
        lambda: client.get("/api/rig", headers=AUTH).json(),
        lambda s: abs(s["thrusters"]["output"][thruster - 1]) > 0.05,
        f"thruster {thruster} commanded",
    )


def _left_safe(client, service, job: dict) -> None:
    """Thrusters zero and disarmed, the brakes engaged: now and in the run's own ending."""
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["armed"] is False and status["thrusters"]["state"] == "DISARMED", status
    assert status["thrusters"]["output"] == [0.0, 0.0]
    assert status["sample"]["channels"]["tow_release"] == 0.0  # the brake engaged
    assert service.session.thrusters.confirmed == (0.0, 0.0)  # the controller said so
    events = service.store.events(job["run_ids"][0])
    safe = [e for e in events if (e.data or {}).get("action") == RunAction.SAFE_STATE]
    assert safe and safe[-1].data["thrusters_zero"] is True, events
    assert "tow_release" in safe[-1].data["brakes_engaged"]


def test_the_rig_names_the_thrusters_telemetry_units(client):
    units = client.get("/api/rig", headers=AUTH).json()["units"]
    assert units["supply_voltage"] == "V"
    assert {k: units[k] for k in ("thruster1_rpm", "thruster2_current")} == {
        "thruster1_rpm": "rpm",
        "thruster2_current": "A",
    }


def test_the_stream_carries_rpm_current_and_voltage_during_a_calibration(client, service):
    job_id = start_job(client, "/api/jobs/calibration", QUICK_CALIBRATION)

    async def first_turning_sample() -> dict:
        async for chunk in sse_events(service.broadcaster, max_hz=None, jobs=False, max_s=60):
            if chunk.startswith(b"event: sample"):
                sample = json.loads(chunk.split(b"data: ", 1)[1])
                channels = sample["channels"]
                if (channels.get("thruster1_rpm") or 0) > 100:
                    return sample
        raise AssertionError("no sample with the thrusters turning within 60 s")

    channels = asyncio.run(first_turning_sample())["channels"]
    # the sweep armed the thrusters, yet a manual run is never queued behind it
    r = client.post(MANUAL, json={"command": 0.2}, headers=AUTH)
    assert r.status_code == 409, r.text
    assert r.json()["detail"].startswith("rig is busy: thrust calibration holds the rig lock")
    for name in ("thruster1_rpm", "thruster2_rpm", "thruster1_current", "thruster2_current"):
        assert isinstance(channels[name], float), (name, channels)
    assert channels["thruster1_current"] > 0 and channels["supply_voltage"] > 10
    job_end = wait_job(client, job_id, timeout_s=60)
    assert job_end["state"] == "completed", how_it_ended(job_end)


def test_manual_thrust_is_refused_to_a_viewer_while_disarmed_and_beyond_the_limits(client, service):
    viewer = {"Authorization": f"Bearer {UserRepository(service.store).add('vic', 'viewer')}"}
    wait_rig_free(client)
    body = {"thruster": 1, "command": 0.3, "duration_s": 2}
    r = client.post(MANUAL, json=body, headers=viewer)
    assert r.status_code == 403 and "needs role operator" in r.json()["detail"], r.text
    client.post("/api/rig/disarm", headers=AUTH)
    r = client.post(MANUAL, json=body, headers=AUTH)
    assert r.status_code == 409, r.text
    assert r.json()["detail"].startswith("thrusters not armed: arm them first")
    _arm(client)
    for bad, says in [
        ({"command": 0.95}, "command: 0.95 is not allowed (allowed -0.8 ≤ command ≤ 0.8"),
        ({"command": -0.81}, "command: -0.81 is not allowed (allowed -0.8 ≤ command ≤ 0.8"),
        ({"thruster": 3}, "thruster: 3 is not allowed (allowed 1 ≤ thruster ≤ 2"),
        ({"duration_s": 61.0}, "duration_s: 61.0 is not allowed (allowed 0 < duration_s ≤ 60 s"),
    ]:
        r = client.post(MANUAL, json=body | bad, headers=AUTH)
        assert r.status_code == 422, r.text
        assert says in r.json()["detail"], (bad, r.json())
    assert client.get("/api/rig", headers=AUTH).json()["current_job"] is None  # nothing ran
    client.post("/api/rig/disarm", headers=AUTH)


def test_manual_thrust_runs_one_thruster_and_returns_to_zero_when_its_time_is_up(client, service):
    _arm(client)
    job_id = start_job(client, MANUAL, {"thruster": 2, "command": 0.4, "duration_s": 1.5})
    job = wait_job(client, job_id, timeout_s=30)
    assert job["state"] == "completed", how_it_ended(job)
    assert job["label"] == "manual thrust: thruster 2 at +0.4 for 1.5 s"
    run = service.store.get_run(job["run_ids"][0])
    assert run.kind == "manual_thrust" and run.parameters["thruster"] == 2
    samples = service.store.samples(run.id)
    rpm1, rpm2 = samples.channels["thruster1_rpm"], samples.channels["thruster2_rpm"]
    assert np.nanmax(rpm2) > 1000 and np.nanmax(np.abs(rpm1)) < 50  # only thruster 2 turned
    assert np.nanmax(samples.channels["thruster2_current"]) > 0.5
    assert np.ptp(samples.channels["load_cell"]) > 1.0  # its thrust on the load cell, N
    _left_safe(client, service, job)


def test_a_page_that_falls_silent_stops_the_thrust(client, service):
    _arm(client)
    # 60 s of the rig's time (6 s of the host's at the paced simulation) outlast the 3 s
    job_id = start_job(client, MANUAL, {"thruster": 1, "command": 0.5, "duration_s": 60})
    assert client.post(f"/api/jobs/{job_id}/alive", headers=AUTH).status_code == 200
    _thrust_on(client, job_id, 1)
    job = wait_job(client, job_id, timeout_s=30)  # no further keep-alive: 3 s, then aborted
    assert job["state"] == "aborted", how_it_ended(job)
    assert job["error"].startswith("dead-man: the page that started it fell silent for 3 s")
    _left_safe(client, service, job)
    r = client.post(f"/api/jobs/{job_id}/alive", headers=AUTH)
    assert r.status_code == 409 and "already ended" in r.json()["detail"]


def test_an_emergency_stop_mid_manual_run_leaves_the_thrusters_at_zero_and_braked(client, service):
    _arm(client)
    job_id = start_job(client, MANUAL, {"thruster": 1, "command": -0.6, "duration_s": 30})
    _thrust_on(client, job_id, 1)
    stop = client.post("/api/rig/emergency-stop", headers=AUTH)
    assert stop.json() == {"aborted_jobs": [job_id], "safe_state": True}
    job = wait_job(client, job_id, timeout_s=30)
    assert job["state"] == "aborted" and "emergency stop" in job["error"], job
    _left_safe(client, service, job)
    r = client.post("/api/rig/arm", headers=AUTH)  # latched: no arming until acknowledged
    assert r.status_code == 409 and "emergency stop" in r.json()["detail"]
    assert client.post("/api/estop/ack", headers=AUTH).status_code == 200
