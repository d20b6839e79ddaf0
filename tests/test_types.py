"""Every package (devices, thrusters, estimation, the API and CLI) type-checks clean under
mypy (configured in pyproject.toml, ``[tool.mypy]``): a wrong type is a CI failure, not a
field bug."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: mypy's incremental cache, shared by every checkout of the user, not the checkout's own
#: ``.mypy_cache``: an entry is reused only for a file of the same content (its hash), mypy
#: version and options, and rewritten atomically, so checkouts and commits can share it. A
#: fresh clone checked from an empty cache in 51 s of CPU (most of it the dependencies'
#: modules); from a warm one, at another path with another venv, in 1.1 s.
CACHE = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "towrig" / "mypy"

pytestmark = pytest.mark.slow


def test_every_package_type_checks_clean():
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--no-error-summary", "--cache-dir", str(CACHE)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"mypy found type errors:\n{done.stdout}{done.stderr}"
