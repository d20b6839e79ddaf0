"""Under ``rig serve``: storage failing mid-tow aborts the job with a one-line error naming
storage, the rig is left safe, and the run's end (and the samples kept aside) is written
as soon as storage takes writes again, while the service runs."""

from __future__ import annotations

import pytest

from api.core.service import RigService
from daq.session import RigSource
from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    simulated_service,
    start_job,
    wait_job,
    wait_job_until,
)
from tests.store.helpers import DbLimits, no_sql
from tests.waiting import read_until

REASON = "storage failed: SQLite: attempt to write a readonly database"


@pytest.fixture(scope="module")
def service(tmp_path_factory) -> RigService:
    root = tmp_path_factory.mktemp("api-storage")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("RIG_SPILL_DIR", str(root / "spill"))
        yield simulated_service(RigSource.load(), f"sqlite:///{root / 'rig.db'}")


def test_storage_failing_mid_tow_aborts_the_job_in_one_line_and_leaves_the_rig_safe(
    client, service
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
    assert client.get(f"/api/runs/{run_id}", headers=AUTH).json()["status"] == "running"

    limits.set()  # storage is back: the service writes back what was kept aside
    run = read_until(
        lambda: client.get(f"/api/runs/{run_id}", headers=AUTH).json(),
        lambda run: run["status"] != "running",
        "the run's end written back",
        timeout_s=30,
        poll_s=0.1,
    )
    assert (run["status"], run["reason"]) == ("aborted", REASON)
    assert run["sample_count"] > job["outcome"]["samples"]  # the kept samples are back
    assert wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))["state"] == ("completed")
