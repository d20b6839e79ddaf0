"""A ``rig`` process loads NumPy's and SciPy's OpenBLAS with one thread each unless the
environment asks for more (``api.cli``'s docstring says why). A real subprocess: the thread
count is fixed when a process loads the library."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: What the ``rig`` entry point imports first, then the two BLAS libraries; prints each
#: library's thread count.
PROBE = (
    "import json\n"
    "import api.cli.main, numpy, scipy.linalg\n"
    "from threadpoolctl import threadpool_info\n"
    "print(json.dumps([i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas']))\n"
)


@pytest.mark.parametrize("asked", [None, "2"])
def test_a_rig_process_runs_blas_on_one_thread_unless_asked(asked: str | None) -> None:
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    if asked is not None:
        env["OPENBLAS_NUM_THREADS"] = asked
    done = subprocess.run(
        [sys.executable, "-c", PROBE], cwd=ROOT, env=env, capture_output=True, text=True,
        timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    threads = json.loads(done.stdout)
    expected = 1 if asked is None else min(int(asked), os.cpu_count() or 1)
    assert len(threads) == 2 and set(threads) == {expected}, threads  # NumPy's and SciPy's
