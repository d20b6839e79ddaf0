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
the real-time modules (``is_realtime``) form one scope, so they run one at a time on one
worker while the other worker runs everything else.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator

import pytest
from xdist.scheduler import LoadScopeScheduling

from tests.pg import PostgresServer, external_postgres, find_postgres_bin, start_postgres

IN_CI = os.environ.get("CI", "").lower() == "true"

#: Folders whose tests drive a rig, a device or a clock in real time.
REALTIME_FOLDERS = (
    "tests/daq/",
    "tests/integration/",
    "tests/procedures/",
    "tests/sim/",
    "tests/thrusters/",
)
#: Other modules that run tests on the simulated rig in real time or assert wall-clock
#: bounds (a stream's pace, the recorder's flush interval).
REALTIME_MODULES = frozenset(
    {
        "tests/api/test_browser.py",
        "tests/api/test_job_queue.py",
        "tests/api/test_jobs.py",
        "tests/api/test_live_ui.py",
        "tests/api/test_operator.py",
        "tests/api/test_pendulum_job.py",
        "tests/api/test_rig_capabilities.py",
        "tests/api/test_reverse_browser.py",
        "tests/api/test_rig_lock.py",
        "tests/api/test_storage_fault_job.py",
        "tests/api/test_stream.py",
        "tests/store/test_recorder.py",
    }
)


def is_realtime(module: str) -> bool:
    """Whether a test module (path from the project root) runs in the real-time scope."""
    return module in REALTIME_MODULES or module.startswith(REALTIME_FOLDERS)


class _ModuleScheduling(LoadScopeScheduling):
    """xdist's loadscope by module, with every real-time module in one scope: they run one
    at a time on one worker (as in a single process), while the other worker takes the
    computing modules (estimation, storage, API reads), so two simulated rigs never compete
    for the two cores of a CI machine. The real-time scope is the largest, so xdist sends it
    first."""

    def _split_scope(self, nodeid: str) -> str:
        module = nodeid.split("::", 1)[0]
        return "realtime" if is_realtime(module) else module


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log) -> LoadScopeScheduling | None:
    """Under ``--dist loadscope``, schedule by module with one scope for the real-time ones.
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
