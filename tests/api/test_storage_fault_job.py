"""Under ``rig serve``: storage failing mid-tow aborts the job with a one-line error naming
storage, the rig is left safe, the run reads ``aborted`` over HTTP at once (not when storage
returns), a job started while storage still fails fails in one line (no traceback), and the
run's end (and the samples kept aside) is written as soon as storage takes writes again,
while the service runs."""

from __future__ import annotations

import pytest

from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    start_job,
    wait_job,
    wait_job_until,
)
from tests.store.helpers import DbLimits, no_sql
from tests.support.waiting import read_until

pytestmark = pytest.mark.rig_service(spill=True)

REASON = "storage failed: SQLite: attempt to write a readonly database"


def test_storage_failing_mid_tow_aborts_the_job_in_one_line_and_leaves_the_rig_safe(
    client, service, caplog
):
    limits = DbLimits(service.store)
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
    wait_job_until(  # released and moving
        client, job_id, lambda job: job["progress"]["message"].startswith("tow:"), "tow moving"
    )
    limits.set(read_only=True)
    job = wait_job(client, job_id, timeout_s=60)
    assert (job["state"], job["error"]) == ("aborted", REASON)
    assert job["progress"]["message"] == f"aborted: {REASON}"
    no_sql(job["progress"]["message"])
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["sample"]["channels"]["tow_release"] == 0.0  # brake engaged
    assert status["lock_holder"] is None
    (run_id,) = job["run_ids"]
    assert service.store.get_run(run_id, as_stored=True).status == "running"  # not stored yet
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()  # ... but it ended
    assert (run["status"], run["reason"]) == ("aborted", REASON)
    assert run["stopped_at"] is not None
    listed = client.get("/api/runs", headers=AUTH).json()
    assert [(r["status"], r["reason"]) for r in listed if r["id"] == run_id] == [
        ("aborted", REASON)
    ]

    # A tow started while storage still fails: failed, one line, no traceback anywhere.
    caplog.clear()
    refused = wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))
    not_started = f"{REASON}; the run was not started"
    assert (refused["state"], refused["error"]) == ("failed", not_started), refused
    assert refused["run_ids"] == []
    assert not [r for r in caplog.records if r.exc_info], "a traceback was logged"
    status = client.get("/api/rig", headers=AUTH).json()
    assert status["sample"]["channels"]["tow_release"] == 0.0
    assert status["lock_holder"] is None

    limits.set()  # storage is back: the service writes back what was kept aside
    read_until(
        lambda: service.store.get_run(run_id, as_stored=True),
        lambda run: run.status != "running",
        "the run's end written back",
        timeout_s=30,
        poll_s=0.1,
    )
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert (run["status"], run["reason"]) == ("aborted", REASON)
    assert run["sample_count"] > job["outcome"]["samples"]  # the kept samples are back
    assert wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))["state"] == ("completed")
