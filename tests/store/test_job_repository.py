"""The job queue's storage (``daq.store.job_repository``) on SQLite and PostgreSQL, in
process: a job left running by a dead process is ``interrupted`` at the next start, a
queued one keeps its place, and an estimation's report files read back byte for byte from
a reopened database.

The real service killed and restarted over these rows is tests/api/test_job_queue.py."""

from __future__ import annotations

import subprocess
import time

import sqlalchemy as sa

from daq.store import Store
from daq.store.job_repository import INTERRUPTED_REASON, JobRepository
from daq.store.schema import JobState, jobs
from tests.store.helpers import new_run

RIG = "BENBAM"


def _job(state: str, position: int | None = None) -> dict:
    return {
        "rig_name": RIG,
        "kind": "tow",
        "label": "tow 24.5 N",
        "state": state,
        "position": position,
        "parameters": {"force_n": 24.5},
        "message": state,
        "run_ids": [],
        "notes": [],
        "created_at": time.time(),
    }


def _owned_by_a_dead_process(store: Store, job_id: str) -> None:
    """Give the job's row the pid of a process that has exited."""
    dead = subprocess.Popen(["true"])
    dead.wait()  # exited and reaped: its pid names no process
    with store.transaction() as conn:
        conn.execute(sa.update(jobs).where(jobs.c.id == job_id).values(owner_pid=dead.pid))


def test_a_dead_owners_running_job_is_interrupted_and_the_queue_keeps_its_order(store):
    repo = JobRepository(store)
    repo.save("running", _job(JobState.RUNNING))
    repo.save("second", _job(JobState.QUEUED, position=2))
    repo.save("first", _job(JobState.QUEUED, position=1))
    repo.save("done", _job(JobState.COMPLETED) | {"finished_at": 1.0})
    repo.save("alive", _job(JobState.RUNNING))  # this process owns it and lives
    for job_id in ("running", "second", "first", "done"):
        _owned_by_a_dead_process(store, job_id)

    assert repo.recover_interrupted(RIG) == ["running"]
    assert repo.recover_interrupted(RIG) == []  # once only
    row = repo.get("running")
    assert row is not None
    assert (row["state"], row["error"]) == (JobState.INTERRUPTED, INTERRUPTED_REASON)
    assert row["finished_at"] is not None
    (event,) = repo.events("running")
    assert event["state"] == JobState.INTERRUPTED and "recovered at start-up" in event["message"]
    assert [j["id"] for j in repo.queued(RIG)] == ["first", "second"]
    assert {j["id"]: j["state"] for j in repo.list_jobs(RIG)} == {
        "running": JobState.INTERRUPTED,
        "second": JobState.QUEUED,
        "first": JobState.QUEUED,
        "done": JobState.COMPLETED,
        "alive": JobState.RUNNING,
    }


def test_report_files_read_back_byte_for_byte_from_a_reopened_database(store):
    result_id = store.add_result([new_run(store)], "estimation", {"k": 1.0})
    png = b"\x89PNG\r\n\x1a\n" + bytes(range(256)) * 4  # every byte value, NUL included
    svg = "<svg>ü</svg>".encode()
    files = [("fit.png", "image/png", png), ("fit.svg", "image/svg+xml", svg)]
    assert JobRepository(store).save_report_files(result_id, files) == ["fit.png", "fit.svg"]
    store.close()

    with Store(store.url) as reopened:
        repo = JobRepository(reopened)
        assert repo.report_names(result_id) == ["fit.png", "fit.svg"]
        assert repo.report_file(result_id, "fit.png") == ("image/png", png)
        assert repo.report_file(result_id, "fit.svg") == ("image/svg+xml", svg)
        assert repo.report_file(result_id, "fit.pdf") is None


def test_jobs_are_listed_a_page_at_a_time_newest_first(store):
    """``rig jobs --limit --offset`` (``api.core.paging.JobsPage``) pages in the database."""
    repo = JobRepository(store)
    for n in range(4):
        repo.save(f"job{n}", _job(JobState.COMPLETED) | {"created_at": 100.0 + n})
    ids = [j["id"] for j in repo.list_jobs(RIG, limit=2, offset=1)]
    assert ids == ["job2", "job1"]
    assert [j["id"] for j in repo.list_jobs(RIG, limit=2, offset=3)] == ["job0"]
