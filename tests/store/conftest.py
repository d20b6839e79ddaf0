"""Storage tests run against SQLite and a real PostgreSQL server.

PostgreSQL comes from ``$RIG_TEST_POSTGRES_URL`` if set, else a throwaway cluster started
from the installed server binaries (tests/pg.py). Without either, the postgresql cases skip
on a laptop and fail under ``CI=true``. Every test gets a fresh, empty database.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from daq.store import Store
from tests.conftest import IN_CI
from tests.pg import PostgresServer, external_postgres, find_postgres_bin, start_postgres

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


@pytest.fixture
def store(db_url: str) -> Iterator[Store]:
    """An open Store on a fresh database."""
    with Store(db_url) as opened:
        yield opened
