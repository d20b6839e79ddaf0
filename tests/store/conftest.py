"""Storage tests run against SQLite and a real PostgreSQL server: every test here that uses
``store`` (tests/conftest.py: a fresh database at head) runs once on each backend, and
``db_url`` gives a fresh, empty database on each."""

from __future__ import annotations

import pytest

from tests.conftest import BACKENDS


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """``store_backend`` over every backend for the tests of this folder."""
    if "store_backend" in metafunc.fixturenames:
        metafunc.parametrize("store_backend", BACKENDS)
