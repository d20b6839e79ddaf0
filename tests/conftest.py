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
the modules in ``TIMING_MODULES`` form one scope, so they run one at a time on one worker.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator

import pytest
from xdist.scheduler import LoadScopeScheduling

from tests.pg import PostgresServer, external_postgres, find_postgres_bin, start_postgres

IN_CI = os.environ.get("CI", "").lower() == "true"

#: Modules that assert wall-clock bounds (clock lateness, reply timeouts, watchdogs, a
#: stream's pace): one xdist scope, so two of them never run at once.
TIMING_MODULES = frozenset(
    {
        "tests/api/test_stream.py",
        "tests/daq/test_acquisition.py",
        "tests/daq/test_plc.py",
        "tests/procedures/test_thruster_link_faults.py",
        "tests/sim/test_plc.py",
        "tests/sim/test_rig.py",
        "tests/store/test_recorder.py",
        "tests/thrusters/test_thruster_driver_emulator.py",
    }
)


class _ModuleScheduling(LoadScopeScheduling):
    """xdist's loadscope by module, with the timing-sensitive modules as one scope."""

    def _split_scope(self, nodeid: str) -> str:
        module = nodeid.split("::", 1)[0]
        return "timing" if module in TIMING_MODULES else module


@pytest.hookimpl(tryfirst=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log) -> LoadScopeScheduling | None:
    """Under ``--dist loadscope``, schedule by module with one scope for TIMING_MODULES.
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
