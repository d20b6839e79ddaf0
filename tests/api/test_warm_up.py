"""``rig warm-up`` leaves the estimator's compiled loop in numba's cache, so the first
estimate after an install loads it instead of compiling it (5-9 s of CPU): a process after
the warm-up integrates both ways an estimate does (the axis simulator and the one-equation
integrator, its grid read off compiled too) with cache hits only. Real subprocesses on a
fresh ``NUMBA_CACHE_DIR``: a process's compile cache is the behaviour."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

#: Integrates as the axis fit and the one-equation fit do; prints the compiled loop's
#: cache hits and misses (numba's dispatcher counts them per signature).
ESTIMATE_LIKE = """
import json
import numpy as np
from estimation.axis.model import simulate
from estimation.axis.prepared_run import prepare
from estimation.motion import compiled
from estimation.motion.equation import Track, integrate
from estimation.motion.terms import LIBRARY, TermValues
from tests.estimation.term_cases import tow_set

runs = [prepare(r) for r in tow_set("10kg", 0)]
simulate(np.array([[10.0, 2.0, 15.0, 0.1]]), ("coulomb_friction",), runs)
tau = np.arange(0.0, 2.0, 0.05)
forces = [TermValues(LIBRARY[n], np.array([[v]])) for n, v in
          (("restoring_spring", 40.0), ("quadratic_damping", 0.4), ("coulomb_friction", 0.1))]
integrate([Track(tau, None, 2.0, 1.0, 0.3)], np.array([[3.0]]), forces,
          np.array([[0.2]]), np.array([[0.0]]), 0.02)
stats = [f.stats for f in (compiled.integrate_grid, compiled.hermite)]
print(json.dumps({"hits": [sum(s.cache_hits.values()) for s in stats],
                  "misses": sum(sum(s.cache_misses.values()) for s in stats)}))
"""


def _run(argv: list[str], env: dict[str, str]) -> str:
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=600,
                          check=False)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.slow
def test_after_warm_up_an_estimate_loads_the_compiled_loop_and_compiles_nothing(tmp_path):
    env = os.environ | {"NUMBA_CACHE_DIR": str(tmp_path / "numba"), "XDG_DATA_HOME": str(tmp_path)}
    said = _run([sys.executable, "-m", "api.cli.main", "warm-up"], env)
    assert said.startswith("estimator kernels ready (")
    counted = json.loads(_run([sys.executable, "-c", ESTIMATE_LIKE], env).splitlines()[-1])
    assert counted == {"hits": counted["hits"], "misses": 0} and min(counted["hits"]) >= 1


def test_the_services_warm_up_stays_in_its_session_out_of_its_ctrl_c():
    """``rig serve``'s background warm-up runs in the service's session, where its nice 19
    counts (a session of its own is a scheduling group of its own on Linux: the compile then
    took as much CPU as the service), and in its own process group, so the terminal's Ctrl-C
    to the service is not its."""
    from api.cli.warm_up import warm_up_in_background

    proc = warm_up_in_background()
    try:
        assert os.getsid(proc.pid) == os.getsid(0)
        assert os.getpgid(proc.pid) == proc.pid != os.getpgid(0)
        autogroup = f"/proc/{proc.pid}/autogroup"
        if os.path.exists(autogroup):  # Linux with autogroup scheduling: the same group
            # (empty for both when a cgroup's cpu controller schedules them instead, as in CI)
            with open(autogroup) as mine, open("/proc/self/autogroup") as ours:
                assert mine.read() == ours.read()
    finally:
        proc.kill()
        proc.wait()
