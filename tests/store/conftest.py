"""Storage tests run against SQLite and a real PostgreSQL server (the ``db_url`` fixture of
tests/conftest.py: a fresh, empty database on each backend; ``store``: one at head)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from daq.store import Store


@pytest.fixture
def store(head_db_url: str) -> Iterator[Store]:
    """An open Store on a fresh database (migrated to head: ``head_db_url``)."""
    with Store(head_db_url) as opened:
        yield opened
