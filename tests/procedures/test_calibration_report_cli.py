"""``rig calibrate-thrusters --report DIR`` against the simulated rig, as a real subprocess:
the calibration is run, stored, and its report written where the operator asked."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from daq.store import Store
from tests.support.cli import run_in_process

RIG = [sys.executable, "-m", "api.cli.main"]
ROOT = Path(__file__).resolve().parents[2]
SWEEP = ["--commands", "0.2,0.5,0.8", "--settle", "0.2", "--samples", "3", "--tare-samples", "5"]


def rig(*args: str, db: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*RIG, *args, "--db", db], capture_output=True, text=True, timeout=180, cwd=ROOT
    )


@pytest.mark.slow
def test_calibrate_thrusters_writes_the_report_of_the_stored_calibration(tmp_path):
    db, out = f"sqlite:///{tmp_path / 'rig.db'}", tmp_path / "report"
    done = rig("calibrate-thrusters", *SWEEP, "--report", str(out), "--json", db=db)
    assert done.returncode == 0, done.stderr
    outcome = json.loads(done.stdout)  # stdout stays the outcome; the report path on stderr
    assert outcome["status"] == "completed"
    assert f"report: {out / 'report.md'}" in done.stderr
    # The controller's RPM and current give the stand figure; the steps, the step response.
    assert sorted(p.name for p in out.iterdir()) == [
        "calibration.png", "calibration.svg", "report.md", "response.png", "response.svg",
        "stand.png", "stand.svg",
    ]  # fmt: skip
    assert "time from the output change [s]" in (out / "response.svg").read_text("utf-8")
    with Image.open(out / "calibration.png") as img:
        assert img.width >= 1000
    assert "command [fraction of full scale]" in (out / "calibration.svg").read_text("utf-8")
    md = (out / "report.md").read_text(encoding="utf-8")
    with Store(db) as store:
        stored = store.results(outcome["run_id"], kind="calibration")[0].data
    assert outcome["run_id"] in md.splitlines()[0]
    rmse = stored["fit"]["rmse_n"]
    assert f"| RMSE of the fit | {rmse:.3g} | N |" in md  # the report is of the stored fit
    gain = stored["fit"]["parameters"]["forward_gain"]
    assert f"| forward_gain | {gain['value']:.5g} ± {gain['std']:.2g} | N |" in md
    assert re.search(r"\| supply voltage, mean \| \d+\.\d\d \(range", md)
    tau = stored["response"]["time_constant_s"]
    assert f"| thrust lag τ (90 % settling) | {tau:.3g} ± " in md
    assert "![" in md and "(calibration.png)" in md


def test_report_into_a_file_is_refused_before_the_rig_moves(tmp_path):
    """Refused while parsing, before anything is opened: in this process (tests/support/cli.py)."""
    db, target = f"sqlite:///{tmp_path / 'rig.db'}", tmp_path / "a-file"
    target.write_text("x")
    argv = ["calibrate-thrusters", "--report", str(target), "--db", db]
    done = run_in_process(argv, cwd=ROOT, env=dict(os.environ))
    assert done.returncode == 2
    assert "--report" in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "rig.db").exists()  # refused while parsing: nothing opened
