"""The published records in ``../shared/data/real/`` (beside the repository, never copied into
it): their path, or a skip on a machine without them (a failure under ``CI=true``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import IN_CI

#: Where the published records live, relative to the repository.
REAL = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"


def real_record(folder: str, name: str) -> Path:
    """``../shared/data/real/<folder>/<name>``; skip when missing, fail when ``CI=true``."""
    path = REAL / folder / name
    if path.is_file():
        return path
    message = f"{path} not found: the published records are read from ../shared/data/real"
    if IN_CI:
        pytest.fail(message + " (required when CI=true)")
    pytest.skip(message)
    raise AssertionError("unreachable")
