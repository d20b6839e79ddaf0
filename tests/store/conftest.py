"""Storage tests run against SQLite and a real PostgreSQL server (the ``db_url`` fixture of
tests/conftest.py: a fresh, empty database on each backend)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from daq.store import Store


@pytest.fixture
def store(db_url: str) -> Iterator[Store]:
    """An open Store on a fresh database."""
    with Store(db_url) as opened:
        yield opened
