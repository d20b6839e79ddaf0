"""Durable run storage: runs, samples, events and results in SQLite (WAL, the default)
or PostgreSQL behind one URL, with Alembic migrations applied on open.

See docs/storage.md. Typical use::

    store = Store()                       # $RIG_DATABASE_URL or ~/.local/share/towrig/rig.db
    run_id = store.create_run(kind="tow", parameters={"force_n": 24.5}, ...)
    recorder = RunRecorder(store, run_id)  # the clock's consumer calls recorder.put(sample)
    run = store.load(run_id)              # in a notebook: run.to_pandas(), run.to_xarray()
"""

from daq.store.csvio import export_run_csv, export_run_json, import_csv
from daq.store.jobs import JobRepository
from daq.store.migrate import default_database_path, default_database_url
from daq.store.recorder import RecorderStats, RunRecorder
from daq.store.records import (
    AmbiguousRunId,
    DuplicateSample,
    EventInfo,
    ResultInfo,
    ResultNotFound,
    RunInfo,
    RunNotFound,
    SampleTable,
)
from daq.store.schema import END_STATUSES, RUN_STATUSES, JobState
from daq.store.store import Store

__all__ = [
    "END_STATUSES",
    "RUN_STATUSES",
    "AmbiguousRunId",
    "DuplicateSample",
    "EventInfo",
    "JobRepository",
    "JobState",
    "RecorderStats",
    "ResultInfo",
    "ResultNotFound",
    "RunInfo",
    "RunNotFound",
    "RunRecorder",
    "SampleTable",
    "Store",
    "default_database_path",
    "default_database_url",
    "export_run_csv",
    "export_run_json",
    "import_csv",
]
