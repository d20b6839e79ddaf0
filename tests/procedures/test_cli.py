"""The `rig` CLI as an operator uses it: runs recorded by real subprocesses, real signals, a
temp database; the store's commands on them in this process (``rig`` below)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

from daq.store import Store
from tests.conftest import copy_sqlite
from tests.support.cli import run_in_process
from tests.support.waiting import wait_until

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

RIG = [sys.executable, "-m", "api.cli.main"]
ROOT = Path(__file__).resolve().parents[2]


#: Commands that drive the rig: real subprocesses here. The store's commands (runs, show,
#: export, import, estimate) run in this process as a fresh one would (tests/support/cli.py).
DRIVING = ("tow", "spin", "pendulum", "calibrate-thrusters", "sequence", "serve", "sim")


def rig(
    *args: str, db: str, timeout: float = 60, refused: bool = False
) -> subprocess.CompletedProcess:
    """``refused``: input the command refuses while parsing, before it opens anything, so
    it runs in this process like the store's commands (as tests/api/test_cli_edges.py)."""
    if args[0] not in DRIVING or refused:
        return run_in_process([*args, "--db", db], cwd=ROOT, env=dict(os.environ))
    return subprocess.run(
        [*RIG, *args, "--db", db], capture_output=True, text=True, timeout=timeout, cwd=ROOT
    )


@pytest.fixture
def db(tmp_path) -> str:
    return f"sqlite:///{tmp_path / 'rig.db'}"


#: The tow the store's commands are tried on (exported, shown, imported back, estimated).
RECORDED_TOW = ("tow", "--force", "44.1", "--max-time", "2", "--baseline", "0.5", "--json")


@pytest.fixture(scope="module")
def recorded_tow(tmp_path_factory) -> tuple[Path, str]:
    """A database holding one tow recorded by a real ``rig tow`` subprocess, and its run id:
    recorded once for the module, each test works on its own copy (``db_with_tow``)."""
    path = tmp_path_factory.mktemp("recorded") / "rig.db"
    result = rig(*RECORDED_TOW, db=f"sqlite:///{path}")
    assert result.returncode == 0, result.stderr
    return path, json.loads(result.stdout)["run_id"]


@pytest.fixture
def db_with_tow(recorded_tow, db) -> tuple[str, str]:
    """``db`` holding a copy of the recorded tow, and the tow's run id."""
    source, run_id = recorded_tow
    return copy_sqlite(source, Path(db.removeprefix("sqlite:///"))), run_id


def _wait_for_samples(db: str, count: int, timeout: float = 20) -> str:
    """The id of the newest run once it has ``count`` samples stored."""

    def stored() -> str | None:
        with Store(db) as store:
            runs = store.list_runs()
            if runs and store.sample_count(runs[0].id) >= count:
                return runs[0].id
        return None

    return wait_until(stored, f"a run with {count} samples stored", timeout_s=timeout, poll_s=0.2)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["tow", "--force", "0"], "--force: 0.0 is not allowed (allowed 0 < |--force| ≤ 100 N"),
        (["tow", "--force", "-150"], "--force: -150.0 is not allowed (allowed 0 < |--force| ≤"),
        (["tow", "--force", "nan"], "--force: nan is not allowed"),
        (["tow", "--force", "150"], "rig limit max_force_n"),
        (["tow", "--force", "10", "--weight", "1"], "give --force or --weight, not both"),
        (["spin", "--torque", "9"], "--torque: 9.0 is not allowed (allowed 0 < |--torque| ≤ 5 N·m"),
        (["spin", "--torque", "-0"], "--torque: -0.0 is not allowed (allowed 0 < |--torque| ≤ 5"),
        (["tow", "--force", "10", "--rig", "fixtures/rigs/missing.toml"], "cannot read rig file"),
    ],
)
def test_bad_input_is_refused_and_writes_nothing(db, args, message):
    result = rig(*args, db=db, refused=True)
    assert "Traceback" not in result.stderr, result.stderr
    assert result.returncode == 2, result.stderr
    assert message in result.stderr
    with Store(db) as store:
        assert store.list_runs() == []


def test_a_negative_force_tows_the_carriage_back_from_the_far_end(db):
    result = rig("tow", "--force", "-24.5", "--max-time", "1.5", "--baseline", "0.3", db=db)
    assert result.returncode == 0, result.stderr
    with Store(db) as store:
        (run,) = store.list_runs()
        x = store.samples(run.id).channels["tow_position"]
    assert run.parameters["force_n"] == pytest.approx(-24.5) and run.status == "completed"
    assert x[0] > 5.0 and x[-1] < x[0] - 0.05  # from the far end, back toward the start


def test_bad_rig_file_names_the_field(db, tmp_path):
    text = (
        (ROOT / "fixtures/rigs/benbam.toml")
        .read_text()
        .replace('transport = "tcp"', 'transport = "udp"')
    )
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    result = rig("tow", "--force", "10", "--rig", str(bad), db=db, refused=True)
    assert result.returncode == 2 and "Traceback" not in result.stderr, result.stderr
    assert "modbus.transport: Input should be 'tcp' or 'rtu' (got 'udp')" in result.stderr


def test_sigkill_mid_run_leaves_an_interrupted_run_missing_at_most_a_second(db):
    proc = subprocess.Popen(
        [*RIG, "tow", "--force", "4.9", "--max-time", "120", "--db", db, "--json"], cwd=ROOT
    )
    try:
        run_id = _wait_for_samples(db, 25)
        time.sleep(0.7)  # kill between flushes, with samples queued: the loss bound is tested
        killed_at = time.time()
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        proc.kill()
    with Store(db) as store:
        assert store.get_run(run_id).status == "running"
    # The next command to open the database (here the operator's `rig runs`) recovers it.
    listed = rig("runs", "--json", db=db)
    assert "marked 1 run(s) left running by a dead process as interrupted" in listed.stderr
    assert [(r["id"], r["status"]) for r in json.loads(listed.stdout)] == [(run_id, "interrupted")]
    with Store(db) as store:
        run = store.get_run(run_id)
        assert run.status == "interrupted"
        last = store.last_sample(run_id)
        assert killed_at - last.t_wall <= 1.0, f"{killed_at - last.t_wall:.2f} s of samples lost"
        assert run.stopped_at.timestamp() == pytest.approx(last.t_wall, abs=1e-3)
        assert store.integrity_check() == "ok"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_aborts_the_run_cleanly_and_records_the_brake(db, sig):
    proc = subprocess.Popen(
        [*RIG, "tow", "--force", "4.9", "--max-time", "120", "--db", db, "--json"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    run_id = _wait_for_samples(db, 15)
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=20)
    assert proc.returncode == 1
    outcome = json.loads(out)
    assert outcome == outcome | {
        "run_id": run_id,
        "status": "aborted",
        "reason": f"operator abort ({sig.name})",
    }
    with Store(db) as store:
        assert store.get_run(run_id).status == "aborted"
        (safe,) = [e for e in store.events(run_id) if e.kind == "safe"]
        assert safe.message.startswith("safe state: brake engaged (tow_release")
        last = store.last_sample(run_id)
        assert last is not None and last.channels["tow_release"] == 0


def test_runs_show_export_import_round_trip(db_with_tow, tmp_path):
    db, run_id = db_with_tow
    listed = json.loads(rig("runs", "--json", db=db).stdout)
    assert [r["id"] for r in listed] == [run_id]
    shown = json.loads(rig("show", run_id[:8], "--json", db=db).stdout)
    assert shown["status"] == "completed" and any(
        e["data"].get("action") == "release" for e in shown["events"] if e["data"]
    )
    csv_path = tmp_path / "run.csv"
    assert rig("export", run_id, "--format", "csv", "-o", str(csv_path), db=db).returncode == 0
    lines = csv_path.read_text().splitlines()
    header = next(line for line in lines if not line.startswith("#")).split(",")
    assert header[0] == "t" and "tow_position" in header
    assert f"# run_id: {run_id}" in lines
    # NetCDF and Parquet from the CLI open in xarray and pandas with units
    for fmt, name in (("netcdf", "run.nc"), ("parquet", "run.parquet")):
        done = rig("export", run_id[:8], "--format", fmt, "-o", str(tmp_path / name), db=db)
        assert done.returncode == 0 and f"wrote {tmp_path / name}" in done.stderr, done.stderr
    with xr.open_dataset(tmp_path / "run.nc") as ds:
        assert ds["tow_position"].attrs["units"] == "m" and ds.attrs["run_id"] == run_id
        assert ds["t_from_release"].attrs["units"] == "s"  # the release event is known
        assert float(ds["t_from_release"][0]) < 0 < float(ds["t_from_release"][-1])
    frame = pd.read_parquet(tmp_path / "run.parquet")
    assert frame.attrs["units"]["tow_position"] == "m" and len(frame) == len(ds["t"])
    # A lab's own CSV (t, position) imports as a new run.
    own = tmp_path / "own.csv"
    own.write_text(
        "t,position,extra\n" + "".join(f"{i * 0.1:.1f},{0.01 * i * i:.5f},1\n" for i in range(40))
    )
    imported = rig("import", str(own), "--kind", "tow", "--force", "24.5", "--weight", "2.5", db=db)
    assert imported.returncode == 0, imported.stderr
    new_id = imported.stdout.strip()
    with Store(db) as store:
        run = store.get_run(new_id)
        assert run.kind == "tow" and run.parameters["force_n"] == 24.5
        assert store.sample_count(new_id) == 40
    exported = json.loads(rig("export", new_id, "--format", "json", db=db).stdout)
    assert exported["run"]["id"] == new_id if "run" in exported else exported["id"] == new_id


def test_import_refuses_bad_csv_and_writes_nothing(db, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,position\n0.0,0.0\n0.1,abc\n")
    result = rig("import", str(bad), "--kind", "tow", "--force", "24.5", db=db)
    assert result.returncode == 2
    assert "line 3" in result.stderr and "position" in result.stderr
    with Store(db) as store:
        assert store.list_runs() == []


def _estimate(run_id: str, db: str) -> dict:
    result = rig("estimate", run_id, "--json", db=db, timeout=120)
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    return data.get("result", data).get("data", data)


@pytest.mark.slow
def test_an_export_imported_back_estimates_the_same_coefficients(db_with_tow, tmp_path):
    """Through the real CLI: a simulated-rig tow, exported, imported as a lab's file would
    be (no events: its tow_release/end_of_travel columns carry the window) and estimated."""
    db, run_id = db_with_tow
    with Store(db) as store:
        hung = store.get_run(run_id).parameters["hung_mass_kg"]
    csv_path = tmp_path / "tow.csv"
    assert rig("export", run_id, "-o", str(csv_path), db=db).returncode == 0
    args = ["--kind", "tow", "--force", "44.1", "--weight", str(hung)]
    imported = rig("import", str(csv_path), *args, "--rig", "fixtures/rigs/benbam.toml", db=db)
    assert imported.returncode == 0, imported.stderr
    original, again = _estimate(run_id, db), _estimate(imported.stdout.strip(), db)
    window = next(iter(again["windows"].values()))
    # The export's own header gives back the recorded release (issue 20: an export imports
    # back as it was); the end is still found from its columns.
    assert window["release_source"] == "release_time_s (given)"
    assert window["end_source"] == "release coil off"
    assert window["samples_dropped_before"] >= 4 and window["spikes_dropped"] == 0
    for name, first in original["coefficients"].items():
        second = again["coefficients"][name]
        # σ_total carries the release timing: host timing of the recorded release, how
        # sharply the data fix the found one
        sigmas = [r["uncertainty"]["parameters"][name] for r in (original, again)]
        assert all(s["std_release_timing"] > 0 for s in sigmas)
        sigma = (sigmas[0]["std_total"] ** 2 + sigmas[1]["std_total"] ** 2) ** 0.5
        assert abs(first["value"] - second["value"]) <= 3 * sigma, (name, first, second, sigmas)
    assert again["rmse_after"] <= 1.5 * original["rmse_after"]
    assert again["effects"] == original["effects"] == []


def test_import_window_options_and_a_time_column_in_ms(db, tmp_path):
    ms = tmp_path / "ms.csv"
    s = np.clip(np.arange(40) * 0.1 - 0.9, 0.0, None)  # released at 0.9 s, damped
    x = 0.3 * (s - 0.8 * -np.expm1(-s / 0.8))
    ms.write_text("t,position\n" + "".join(f"{i * 100},{v:.4f}\n" for i, v in enumerate(x)))
    refused = rig("import", str(ms), "--kind", "tow", "--force", "24.5", db=db)
    assert refused.returncode == 2
    assert "column 't': median step 100 between samples, expected seconds" in refused.stderr
    assert "--time-unit ms" in refused.stderr
    bad = rig(
        "import", str(ms), "--kind", "tow", "--force", "24.5", "--time-unit", "ms",
        "--release-time", "9", db=db,
    )  # fmt: skip
    assert bad.returncode == 2 and "--release-time: 9.0 is not allowed" in bad.stderr
    ok = rig(
        "import", str(ms), "--kind", "tow", "--force", "24.5", "--time-unit", "ms",
        "--release-time", "0.9", "--end-time", "3.5", db=db,
    )  # fmt: skip
    assert ok.returncode == 0, ok.stderr
    with Store(db) as store:
        params = store.get_run(ok.stdout.strip()).parameters
    assert params["release_time_s"] == pytest.approx(0.9)
    assert params["end_time_s"] == pytest.approx(3.5)
    window = next(iter(_estimate(ok.stdout.strip(), db)["windows"].values()))
    assert window["release_source"] == "release_time_s (given)"
    assert window["end_source"] == "end_time_s (given)"
    assert window["release_time_s"] == pytest.approx(0.9, abs=1e-6)
    # Times a person reads: from the first sample, and the end from the release.
    assert window["release_from_start_s"] == pytest.approx(0.9, abs=1e-6)
    assert window["end_from_release_s"] == pytest.approx(2.6, abs=1e-6)
    text = rig("estimate", ok.stdout.strip(), db=db).stdout
    assert "release 0.900 s after the first sample (release_time_s (given); run clock" in text
    assert "end 2.600 s after it" in text
