"""Durable run storage: runs, samples, events and results in SQLite (WAL, the default)
or PostgreSQL behind one URL, with Alembic migrations applied on open.

See docs/storage.md. Typical use::

    store = Store()                       # $RIG_DATABASE_URL or ~/.local/share/towrig/rig.db
    run_id = store.create_run(kind="tow", parameters={"force_n": 24.5}, ...)
    recorder = RunRecorder(store, run_id)  # the clock's consumer calls recorder.put(sample)
"""

from typing import TYPE_CHECKING, Any

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
from daq.store.schema import END_STATUSES, RUN_STATUSES
from daq.store.store import Store

if TYPE_CHECKING:
    from daq.store.csvio import export_run_csv, export_run_json, import_csv

#: Names served from daq.store.csvio on first use (it imports numpy and the estimator's
#: CSV rules; listing runs needs neither).
_CSVIO = ("export_run_csv", "export_run_json", "import_csv")


def __getattr__(name: str) -> Any:
    if name in _CSVIO:
        from daq.store import csvio

        return getattr(csvio, name)
    raise AttributeError(f"module 'daq.store' has no attribute {name!r}")


__all__ = [
    "END_STATUSES",
    "RUN_STATUSES",
    "AmbiguousRunId",
    "DuplicateSample",
    "EventInfo",
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
