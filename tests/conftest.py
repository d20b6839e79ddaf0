"""Shared test configuration.

Tests that need an outside program (mbpoll, chromium, a PostgreSQL server) call
``require_tool`` or use ``postgres_server``: on a developer's laptop they skip when it is
missing, but with ``CI=true`` they fail, so CI can never go green by skipping them.

``db_url`` gives a fresh, empty database on each backend: SQLite, and PostgreSQL from
``$RIG_TEST_POSTGRES_URL`` if set, else a throwaway cluster started from the installed
server binaries (tests/pg.py).

Lanes and workers (pyproject.toml): ``pytest`` runs the fast lane (``-m 'not slow'``) on
two xdist workers; ``pytest -m ""`` runs everything (CI). Tests are scheduled by module
(``--dist loadscope``), so module-scoped fixtures (recorded runs, servers) are built once;
the real-time modules form two scopes (``realtime_scope``), one per worker, so each worker
runs at most one real-time test at a time.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator

import pytest
from xdist.scheduler import LoadScopeScheduling

from tests.pg import PostgresServer, external_postgres, find_postgres_bin, start_postgres

IN_CI = os.environ.get("CI", "").lower() == "true"

#: Folders whose tests drive a device or the rig's procedures in real time.
DEVICE_FOLDERS = ("tests/daq/", "tests/procedures/", "tests/sim/", "tests/thrusters/")
#: Other modules that run tests on the simulated rig in real time (the chains, the service's
#: jobs and pages) or assert wall-clock bounds (a stream's pace, the recorder's flushes).
SERVICE_FOLDERS = ("tests/integration/",)
SERVICE_MODULES = frozenset(
    {
        "tests/api/test_browser.py",
        "tests/api/test_job_queue.py",
        "tests/api/test_jobs.py",
        "tests/api/test_live_ui.py",
        "tests/api/test_operator.py",
        "tests/api/test_pendulum_job.py",
        "tests/api/test_reverse_browser.py",
        "tests/api/test_rig_capabilities.py",
        "tests/api/test_rig_lock.py",
        "tests/api/test_storage_fault_job.py",
        "tests/api/test_submission_checks.py",
        "tests/api/test_people.py",
        "tests/api/test_estop_browser.py",
        "tests/api/test_stream.py",
        "tests/store/test_recorder.py",
    }
)


def realtime_scope(module: str) -> str | None:
    """The real-time scope of a test module (path from the project root), or None for a
    module that only computes (estimation, storage, API reads and checks)."""
    if module.startswith(DEVICE_FOLDERS):
        return "realtime-devices"
    if module in SERVICE_MODULES or module.startswith(SERVICE_FOLDERS):
        return "realtime-service"
    return None


class _ModuleScheduling(LoadScopeScheduling):
    """xdist's loadscope by module, with the real-time modules in two scopes (device and
    procedure tests; chains and service tests) of about equal length: each worker runs one
    of them, one test at a time, so at most two real-time tests run at once on a 2-core
    machine, one per core, and the computing modules fill the gaps. The two scopes hold the
    most tests, so xdist sends them first, one to each worker."""

    def _split_scope(self, nodeid: str) -> str:
        module = nodeid.split("::", 1)[0]
        return realtime_scope(module) or module


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log) -> LoadScopeScheduling | None:
    """Under ``--dist loadscope``, schedule by module with two scopes for the real-time ones.
    (xdist's own ``loadgroup`` silently stops grouping on pytest 9.2, pytest-xdist#1386.)"""
    if config.getvalue("dist") != "loadscope":
        return None
    return _ModuleScheduling(config, log)


def require_tool(name: str, why: str) -> str:
    """Path of the executable ``name``; skip (or fail under CI=true) when missing."""
    path = shutil.which(name)
    if path:
        return path
    message = f"{name} not found: {why}"
    if IN_CI:
        pytest.fail(message + " (required when CI=true)")
    pytest.skip(message)
    raise AssertionError("unreachable")


BACKENDS = ["sqlite", "postgresql"]


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """One PostgreSQL server for the whole session."""
    url = os.environ.get("RIG_TEST_POSTGRES_URL", "").strip()
    if url:
        server = external_postgres(url)
    elif find_postgres_bin() is not None:
        server = start_postgres()
    else:
        message = "no PostgreSQL: set RIG_TEST_POSTGRES_URL or install postgresql (initdb)"
        if IN_CI:
            pytest.fail(message + " (required when CI=true)")
        pytest.skip(message)
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture(params=BACKENDS)
def db_url(request: pytest.FixtureRequest, tmp_path) -> Iterator[str]:
    """URL of a fresh, empty database on each backend."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'rig.db'}"
        return
    server: PostgresServer = request.getfixturevalue("postgres_server")
    url = server.create_database()
    try:
        yield url
    finally:
        server.drop_database(url)
