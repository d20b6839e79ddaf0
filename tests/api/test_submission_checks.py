"""Validation at submission (issue 23): a thruster drive beyond the stored calibration is
refused when it is queued (422 naming the field and the calibrated range), not when it
reaches the rig; a sequence with such a later step is refused before step 1; a sequence
queued before the calibration changed is checked again when it starts, before it moves."""

from __future__ import annotations

import re

import pytest

from api.core.job_requests import procedure_from_request
from tests.api.conftest import AUTH, how_it_ended, start_job, wait_job

pytestmark = pytest.mark.simtime

#: Five commands each way: the fewest a calibration fits; ~14 s on the simulated rig.
QUICK_CALIBRATION = {
    "commands": [0, 0.2, 0.4, 0.6, 0.8],
    "settle_s": 0.3,
    "samples_per_step": 2,
    "tare_samples": 2,
}
RANGE = re.compile(r"allowed (-[\d.]+) … ([\d.]+) N: the thrusters' calibrated range")


def _counts(client) -> tuple[int, int]:
    jobs = client.get("/api/jobs", headers=AUTH).json()
    runs = client.get("/api/runs", headers=AUTH).json()
    return len(jobs), len(runs["runs"] if isinstance(runs, dict) else runs)


def test_a_thruster_tow_without_a_calibration_is_refused_at_submission(client) -> None:
    before = _counts(client)
    r = client.post("/api/jobs/tow", json={"force_n": 20, "drive": "thrusters"}, headers=AUTH)
    assert r.status_code == 422, r.text
    assert r.json()["errors"][0]["field"] == "drive"
    assert "rig calibrate-thrusters" in r.json()["detail"]
    assert _counts(client) == before


@pytest.fixture(scope="module")
def calibrated(client) -> None:
    job = wait_job(
        client, start_job(client, "/api/jobs/calibration", QUICK_CALIBRATION), timeout_s=60
    )
    assert job["state"] == "completed", how_it_ended(job)


def test_a_70_n_thruster_tow_beyond_the_calibration_is_refused_with_the_range(
    client, calibrated
) -> None:
    before = _counts(client)
    r = client.post("/api/jobs/tow", json={"force_n": 70, "drive": "thrusters"}, headers=AUTH)
    assert r.status_code == 422, r.text
    error = r.json()["errors"][0]
    assert error["field"] == "force_n" and error["value"] == 70
    low, high = map(float, RANGE.search(error["allowed"]).groups())
    assert -60 < low < -40 and 55 < high < 70  # 2 thrusters × (−25…32 N at command 0.8)
    assert _counts(client) == before  # nothing queued, nothing recorded
    inside = client.post(
        "/api/jobs/tow?queue=false",
        json={"force_n": 0.9 * high, "drive": "thrusters", "max_time_s": 0.5},
        headers=AUTH,
    )
    assert inside.status_code == 202, inside.text  # the range it names is the one it takes
    client.post(f"/api/jobs/{inside.json()['id']}/abort", headers=AUTH)
    wait_job(client, inside.json()["id"])


def test_a_sequence_with_a_bad_later_step_is_refused_before_step_1(client, calibrated) -> None:
    before = _counts(client)
    steps = [
        {"kind": "tow", "force_n": 20, "max_time_s": 1},
        {"kind": "spin", "torque_nm": 0.3, "max_time_s": 1},
        {"kind": "tow", "force_n": 70, "drive": "thrusters"},
    ]
    r = client.post("/api/jobs/sequence", json={"steps": steps}, headers=AUTH)
    assert r.status_code == 422, r.text
    assert [e["field"] for e in r.json()["errors"]] == ["steps[2].force_n"]
    assert RANGE.search(r.json()["detail"])
    assert _counts(client) == before


def test_a_queued_sequence_is_checked_again_when_it_starts(client, service, calibrated) -> None:
    """Parsed without the store (as a sequence queued before a weaker calibration was
    stored): the start refuses it before step 1 records anything."""
    runner = client.app.state.runner
    body = {
        "steps": [
            {"kind": "tow", "force_n": 20},
            {"kind": "tow", "force_n": -70, "drive": "thrusters"},
        ]
    }
    seq, label = procedure_from_request("sequence", body, service.source.rig)
    _, runs_before = _counts(client)
    job = runner.start_procedure("sequence", seq, label, request=body)
    ended = wait_job(client, job.id)
    assert ended["state"] == "failed", how_it_ended(ended)
    assert ended["error"].startswith("steps[1].force_n: -70.0 is not allowed")
    assert ended["run_ids"] == [] and _counts(client)[1] == runs_before
