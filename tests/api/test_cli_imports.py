"""What a ``rig`` command imports in a fresh process: only what it uses (issue 33). Each
package left out is CPU saved on every call (``python -X importtime``): statsmodels with
pandas ~1 s, scipy.signal with scipy.stats ~1 s, scipy.integrate ~0.3 s, scipy.ndimage
~0.07 s. A real subprocess:
what a process imports is the behaviour."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from daq.csv_to_store import import_csv
from daq.store import Store
from tests.integration.test_import_kinds import _tow_csv

#: Prints the modules the command loaded and how many full (generation 2) collections it
#: ran when the process ends (after ``sys.exit``).
PROBE = (
    "import atexit, gc, json, sys\n"
    "full = []\n"
    "gc.callbacks.append(lambda phase, info: phase == 'stop' and info['generation'] == 2\n"
    "                    and full.append(info))\n"
    "atexit.register(lambda: print(json.dumps({'modules': sorted(sys.modules),\n"
    "                                          'full': len(full)}), file=sys.stderr))\n"
    "from api.cli.main import main\n"
    "sys.argv[0] = 'rig'\n"
    "main()\n"
)
#: Never loaded by an estimate (pandas and statsmodels: notebooks' and tests' tools); nor,
#: by a tow's, the pendulum's estimator (``--method`` lists its methods by name only).
NOT_FOR_AN_ESTIMATE = (
    "statsmodels", "pandas", "scipy.stats", "scipy.signal", "scipy.integrate", "scipy.ndimage",
    "matplotlib", "fastapi", "pymodbus", "estimation.pendulum.pendulum_estimate",
)  # fmt: skip
#: Never loaded by ``rig --help`` (it lists commands from a table) nor ``rig runs`` (a plain
#: table: rich's cost ~0.25 s of CPU for 50 rows, 15 s for 7,000; its filters' options need
#: ``daq.procedures.flag``, not the procedures' request models, ~0.1 s; a store at its head
#: revision needs no Alembic; only a checkout without metadata reads its pyproject.toml;
#: its page and filters at their defaults build no model, so pydantic never scans the
#: installed packages for plugins, ~0.05 s).
NOT_FOR_A_LIST = (
    "numpy", "scipy", "pandas", "statsmodels", "numba", "matplotlib", "fastapi", "pymodbus",
    "rich", "alembic", "daq.procedures.procedure_request", "daq.procedures.requests", "tomllib",
    "pydantic.plugin._loader",
)  # fmt: skip
#: Nor by ``rig --help``, which reads no database and no registry: SQLAlchemy ~0.5 s of CPU,
#: the run-kind registry's request models (pydantic, the rig file's schema) ~0.4 s.
NOT_FOR_THE_HELP = (*NOT_FOR_A_LIST, "sqlalchemy", "pydantic", "daq.config",
                    "daq.procedures.run_kinds")  # fmt: skip


def _probed(tmp_path: Path, *argv: str) -> dict:
    """PROBE's report of the command ``argv`` run in a fresh process."""
    env = os.environ | {"RIG_DATABASE_URL": f"sqlite:///{tmp_path}/rig.db",
                        "XDG_DATA_HOME": str(tmp_path), "RIG_API_TOKEN": "t"}  # fmt: skip
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, *argv], cwd=tmp_path, env=env, capture_output=True,
        text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stderr.strip().splitlines()[-1])


def _loaded(tmp_path: Path, *argv: str) -> set[str]:
    return set(_probed(tmp_path, *argv)["modules"])


def _one_stored_tow(tmp_path: Path) -> str:
    store = Store(f"sqlite:///{tmp_path}/rig.db")
    _tow_csv(tmp_path / "tow.csv", 20.0, 1)
    run = import_csv(store, tmp_path / "tow.csv", kind="tow", parameters={"force_n": 20.0})
    store.close()
    return run


@pytest.mark.slow
def test_an_estimate_imports_no_statsmodels_pandas_or_scipy_stats(tmp_path):
    store = Store(f"sqlite:///{tmp_path}/rig.db")
    ids = []
    for mean, seed in ((20.0, 1), (45.0, 2)):
        _tow_csv(tmp_path / f"tow{seed}.csv", mean, seed)
        run = import_csv(store, tmp_path / f"tow{seed}.csv", kind="tow",
                         parameters={"force_n": mean})  # fmt: skip
        ids.append(run)
    store.close()
    probed = _probed(tmp_path, "estimate", *ids)
    loaded = set(probed["modules"])
    assert "estimation.motion.term_search" in loaded  # it did search for effects
    assert [m for m in NOT_FOR_AN_ESTIMATE if m in loaded] == []
    # what the fit loads as it goes (scipy.optimize, numba) lives to the end: no full
    # collection walks it (``api.cli.estimate.ESTIMATING``; one was 0.04-0.08 s of CPU)
    assert probed["full"] == 0
    # weight-driven imports: no thruster drive to rebuild, so no thrust law (SciPy's splines)
    assert [m for m in ("daq.thruster_run_drive", "scipy.interpolate") if m in loaded] == []


@pytest.mark.parametrize(
    ("argv", "never"),
    [(("--help",), NOT_FOR_THE_HELP), (("runs",), NOT_FOR_A_LIST),
     (("estimate", "--help"), NOT_FOR_AN_ESTIMATE)],
)  # fmt: skip
def test_help_the_run_list_and_the_estimate_command_import_only_what_they_use(
    tmp_path, argv, never
):
    """The fast lane's guard (the estimate itself is timed above, in the slow lane):
    ``rig estimate --help`` loads the estimate command's modules, as every estimate does."""
    if argv == ("runs",):
        _one_stored_tow(tmp_path)
    loaded = _loaded(tmp_path, *argv)
    assert [m for m in never if m in loaded] == []


#: Never loaded by the rig service's own process: the fits, simulations and plans that use
#: them run in the analysis worker (api.core.analysis_executor). scipy.optimize with the
#: linear algebra it pulls in is +23 MB resident on every `rig serve`; scipy.special, for
#: the few statistics functions the budgets and misfit tests call, +27 MB with the
#: array-API shims it imports (numpy.testing, numpy.f2py) (docs/api.md, Memory).
NOT_FOR_THE_SERVICE = (
    "scipy", "scipy.optimize", "scipy.integrate", "scipy.linalg", "scipy.signal",
    "scipy.stats", "scipy.special", "statsmodels", "pandas", "matplotlib", "numba",
)  # fmt: skip


def test_the_service_process_imports_no_optimizer_integrator_or_plotting(tmp_path):
    probe = "import json, sys\nimport api.http.app\nprint(json.dumps(sorted(sys.modules)))\n"
    proc = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True,
        timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    loaded = set(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert "api.core.campaign" in loaded  # it did load the routes that plan and fit
    assert [m for m in NOT_FOR_THE_SERVICE if m in loaded] == []


#: The service started as ``rig serve`` starts it (its simulated rig in real time), then every
#: read route without a path parameter answered (those the browser loads first: the kinds
#: with their units, the runs, the results, …); the modules loaded meanwhile are printed.
SERVED_PROBE = """
import json, sys
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient
from api.core.service import RigService
from api.http.app import create_app
from daq.session import RigSource
app = create_app(RigService(RigSource.load(), "sqlite:///rig.db"), token="t")
with TestClient(app) as client:
    before = set(sys.modules)
    for route in app.routes:
        if isinstance(route, APIRoute) and "GET" in route.methods and "{" not in route.path:
            if "stream" not in route.path:  # an event stream never ends
                answer = client.get(route.path, headers={"Authorization": "Bearer t"})
                assert answer.status_code < 500, (route.path, answer.text)
print(json.dumps(sorted(set(sys.modules) - before)))
"""


def test_serving_the_read_routes_imports_nothing_the_service_never_loads(tmp_path):
    """Not even on a request: an import in one of the service's threads holds the GIL while
    an extension module initialises, and a loaded machine can take the CPU from that thread
    meanwhile, so the clock's real-time thread waits for the GIL. The first page load did
    import ``scipy.special`` (the kinds' units, ``estimation.axis.crosscheck_comparison``):
    beside 8 busy loops a 10 ms real-time ticker was 232 ms late once in 12 such imports
    (22-38 ms in the others, 18-28 ms beside plain Python), and CI's browser tow at b7981f9
    lost two slots seconds after it."""
    proc = subprocess.run(
        [sys.executable, "-c", SERVED_PROBE], cwd=tmp_path, capture_output=True, text=True,
        env=os.environ | {"XDG_DATA_HOME": str(tmp_path)}, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    loaded = set(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert [m for m in NOT_FOR_THE_SERVICE if m in loaded] == []


def test_the_run_list_walks_its_loaded_modules_in_no_full_collection(tmp_path):
    """What ``rig runs`` loads (SQLAlchemy, the store, pydantic) lives to the end of the
    process: loaded with the collector paused and frozen after (``daq.collector``), no full
    collection walks it (one was ~0.04 s, all collections ~0.1 s of its CPU; issue 33)."""
    _one_stored_tow(tmp_path)
    probed = _probed(tmp_path, "runs")
    assert "sqlalchemy" in probed["modules"]  # it did load the store
    assert probed["full"] == 0


#: Nor by ``rig show``: one run builds no filter options (pydantic, ~0.1 s of CPU).
NOT_FOR_ONE_RUN = (*NOT_FOR_A_LIST, "pydantic", "api.cli.options")


def test_showing_a_run_imports_no_filter_options_nor_pydantic(tmp_path):
    loaded = _loaded(tmp_path, "show", _one_stored_tow(tmp_path))
    assert "sqlalchemy" in loaded  # it did read the run
    assert [m for m in NOT_FOR_ONE_RUN if m in loaded] == []
