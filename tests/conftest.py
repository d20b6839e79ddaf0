"""Shared test configuration.

Tests that need an outside program (mbpoll, chromium, a PostgreSQL server) call
``require_tool``: on a developer's laptop they skip when it is missing, but with
``CI=true`` they fail, so CI can never go green by skipping them.
"""

from __future__ import annotations

import os
import shutil

import pytest

IN_CI = os.environ.get("CI", "").lower() == "true"


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
