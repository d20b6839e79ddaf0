"""Every package (devices, thrusters, estimation, the API and CLI) type-checks clean under
mypy (configured in pyproject.toml, ``[tool.mypy]``): a wrong type is a CI failure, not a
field bug."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def test_every_package_type_checks_clean():
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--no-error-summary"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"mypy found type errors:\n{done.stdout}{done.stderr}"
