"""Durable run storage: runs, samples, events and results in SQLite (WAL, the default)
or PostgreSQL behind one URL, with Alembic migrations applied on open.

See docs/storage.md. Typical use::

    store = Store()                       # $RIG_DATABASE_URL or ~/.local/share/towrig/rig.db
    run_id = store.create_run(kind="tow", parameters={"force_n": 24.5}, ...)
    recorder = RunRecorder(store, run_id)  # the clock's consumer calls recorder.put(sample)
    run = store.load(run_id)              # in a notebook: run.to_pandas(), run.to_xarray()
"""

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from daq.store.csv_export import export_run_csv, export_run_json
    from daq.store.job_repository import JobRepository
    from daq.store.loaded_run import LoadedRun
    from daq.store.migrate import default_database_path, default_database_url
    from daq.store.recorder import RecorderStats, RunRecorder
    from daq.store.run_records import (
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

#: Where each public name lives; imported on first use, so ``daq.store.run_metadata`` or
#: ``daq.store.run_records`` come without SQLAlchemy, and listing runs without numpy. A CSV
#: import is ``daq.csv_to_store.import_csv`` (it reads with estimation's CSV rules).
_HOME = {
    "export_run_csv": "csv_export",
    "export_run_json": "csv_export",
    "default_database_path": "migrate",
    "default_database_url": "migrate",
    "RecorderStats": "recorder",
    "RunRecorder": "recorder",
    "END_STATUSES": "schema",
    "RUN_STATUSES": "schema",
    "JobState": "schema",
    "JobRepository": "job_repository",
    "LoadedRun": "loaded_run",
    "Store": "store",
    **dict.fromkeys(
        ("AmbiguousRunId", "DuplicateSample", "EventInfo", "ResultInfo", "ResultNotFound",
         "RunInfo", "RunNotFound", "SampleTable"),
        "run_records",
    ),
}  # fmt: skip


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'daq.store' has no attribute {name!r}")
    return getattr(import_module(f"daq.store.{home}"), name)


__all__ = [
    "END_STATUSES",
    "RUN_STATUSES",
    "AmbiguousRunId",
    "DuplicateSample",
    "EventInfo",
    "JobRepository",
    "JobState",
    "LoadedRun",
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
]
