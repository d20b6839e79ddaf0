"""Published records nobody on the project wrote, read where the project keeps them: the
``shared/data`` folder beside the checkout (``../shared/data`` from the repository root; CI
has it). A missing file skips the test on a laptop and fails it under ``CI=true``."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import IN_CI

SHARED_DATA = Path(__file__).resolve().parents[3] / "shared" / "data"


def shared_file(*parts: str) -> Path:
    """``shared/data/<parts>``; skip (or fail under CI=true) when it is not there."""
    path = SHARED_DATA.joinpath(*parts)
    if path.is_file():
        return path
    message = f"published data not found: {path}"
    if IN_CI:
        pytest.fail(message + " (required when CI=true)")
    pytest.skip(message)
    raise AssertionError("unreachable")
