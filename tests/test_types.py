"""The device, thruster and estimation layers type-check clean under mypy (configured in
pyproject.toml, ``[tool.mypy]``): a wrong type there is a CI failure, not a field bug."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


def test_daq_thrusters_and_estimation_type_check_clean():
    done = subprocess.run(
        [sys.executable, "-m", "mypy", "--no-error-summary"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, f"mypy found type errors:\n{done.stdout}{done.stderr}"
