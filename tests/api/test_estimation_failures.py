"""A fit that fails in its numerics is ours, not the user's, at every face: ``rig estimate``
exits 1 with one line ``could not fit …: why`` (bad input stays exit 2, naming the field),
an estimation job ends ``failed`` with that line (bad input is a 422 before any job), and
``RIG_DEBUG=1`` shows the traceback behind any error."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import estimation
from api.core.analysis_executor import ThreadExecutor
from api.core.estimation_failure import EstimationFailure
from api.core.estimation_job import run_estimation
from daq.csv_to_store import import_csv
from tests.api.conftest import AUTH, wait_job
from tests.integration.test_import_kinds import _tow_csv
from tests.support.cli import RigCli
from tests.support.shared_data import shared_file

CSV = {"Content-Type": "text/csv"}
#: What the numerics raise when a fit breaks down (numpy with seterr, scipy, linalg).
NUMERIC = [
    FloatingPointError("overflow encountered in exp"),
    ValueError("array must not contain infs or NaNs"),
    np.linalg.LinAlgError("Singular matrix"),
    RuntimeError("Optimal parameters not found: Number of calls to function has reached maxfev"),
]


def _broken_fit(err: Exception):
    def estimate(*args, **kwargs):
        raise err

    return estimate


@pytest.mark.parametrize("err", NUMERIC, ids=lambda e: type(e).__name__)
def test_a_numerical_failure_is_an_estimation_failure_and_stores_nothing(
    store, tmp_path, monkeypatch, err
) -> None:
    _tow_csv(tmp_path / "tow.csv", 30.0, 1)
    run = import_csv(store, tmp_path / "tow.csv", kind="tow", parameters={"force_n": 30.0})
    monkeypatch.setattr(estimation, "estimate", _broken_fit(err))
    with pytest.raises(EstimationFailure) as caught:
        run_estimation(store, [run])
    assert str(caught.value) == f"could not fit surge of run {run[:8]}: {err}"
    assert caught.value.__cause__ is err  # the traceback behind it is kept
    assert store.results(run) == []


def test_the_failure_line_names_the_floating_point_errors_before_it(
    store, tmp_path, monkeypatch
) -> None:
    """numpy's overflow/invalid warnings are noted, not printed, and said in the line."""
    _tow_csv(tmp_path / "tow.csv", 30.0, 1)
    run = import_csv(store, tmp_path / "tow.csv", kind="tow", parameters={"force_n": 30.0})

    def overflowing(*args, **kwargs):
        np.exp(np.array([1000.0])) - np.inf  # overflow, then inf - inf: invalid
        raise ValueError("array must not contain infs or NaNs")

    monkeypatch.setattr(estimation, "estimate", overflowing)
    with pytest.raises(EstimationFailure, match=r"NaNs \(after overflow, invalid value in the "):
        run_estimation(store, [run])
    assert np.geterr()["over"] == "warn"  # the error state outside is untouched


def test_bad_input_is_found_before_fitting_and_names_the_field(store, tmp_path) -> None:
    (tmp_path / "short.csv").write_text("t,position\n0,0\n0.1,0.01\n0.2,0.03\n")
    run = import_csv(store, tmp_path / "short.csv", kind="tow", parameters={"force_n": 1.0})
    with pytest.raises(ValueError, match=r"t: got '\d samples after release', allowed: >= 5"):
        run_estimation(store, [run])


def _import_ship2d(rig: RigCli) -> str:
    record = shared_file("real", "ship2d-regular-waves", "ship2d_3111_2_20Hz.csv")
    argv = ["import", str(record), "--kind", "tow", "--drive-column", "force_sway_N"]
    return rig(*argv, "--drive-unit", "N").stdout.strip()


@pytest.mark.slow  # a fit of the whole published record: the longest test of the fast lane
def test_the_ship2d_record_never_ends_as_bad_input(tmp_path: Path) -> None:
    """The README's commands on the floating section: it estimates, or it fails as ours (exit
    1, one line naming what could not be fitted) — never exit 2 as if the user's input were
    wrong (it said "error: array must not contain infs or NaNs", exit 2)."""
    rig = RigCli(tmp_path)
    run = _import_ship2d(rig)
    proc = subprocess.run(
        [sys.executable, "-m", "api.cli.main", "estimate", run, "--no-effects"],
        cwd=tmp_path, env=rig.env | {"RIG_DEBUG": ""}, capture_output=True, text=True,
        timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode in (0, 1), proc.stderr
    assert "Traceback" not in proc.stderr and "Warning" not in proc.stderr
    if proc.returncode == 1:
        assert proc.stderr.startswith(f"error: could not fit surge of run {run[:8]}: ")
        assert proc.stderr.count("\n") == 1, proc.stderr


def test_rig_debug_shows_the_traceback_of_bad_input_too(tmp_path: Path) -> None:
    rig = RigCli(tmp_path)
    rig.env.pop("RIG_DEBUG", None)
    env = rig.env | {"RIG_DEBUG": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "api.cli.main", "show", "0123abcd"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert proc.returncode == 2
    assert proc.stderr.startswith("Traceback (most recent call last):")
    assert proc.stderr.splitlines()[-1].startswith("error: no run with id '0123abcd'")
    quiet = rig("show", "0123abcd", code=2)  # without it: the one line only
    assert quiet.stderr.startswith("error: no run with id") and quiet.stderr.count("\n") == 1


@pytest.mark.usefixtures("imports_in_a_thread")  # its uploads are not what it tests
def test_the_api_tells_a_failed_fit_from_bad_input(client, tmp_path, monkeypatch) -> None:
    _tow_csv(tmp_path / "tow.csv", 30.0, 2)
    r = client.post("/api/runs/import?kind=tow&force_n=30", content=(tmp_path / "tow.csv")
                    .read_bytes(), headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    run = r.json()["run_id"]
    monkeypatch.setattr(estimation, "estimate", _broken_fit(NUMERIC[0]))
    # the fit patched above runs in this process (the service's runs it in a worker process)
    analysis = client.app.state.runner.analysis
    monkeypatch.setattr(analysis, "executor", ThreadExecutor(client.app.state.service.store))
    r = client.post("/api/jobs/estimation", json={"run_ids": [run]}, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=60)
    assert job["state"] == "failed"
    assert job["error"] == f"could not fit surge of run {run[:8]}: overflow encountered in exp"

    short = b"t,position\n0,0\n0.1,0.01\n0.2,0.03\n"
    r = client.post("/api/runs/import?kind=tow&force_n=1", content=short, headers=AUTH | CSV)
    r = client.post("/api/jobs/estimation", json={"run_ids": [r.json()["run_id"]]}, headers=AUTH)
    assert r.status_code == 422, r.text  # bad input: no job at all
    assert "t: got '2 samples after release', allowed: >= 5 samples" in r.json()["detail"]
