"""The `rig` CLI as an operator uses it: real subprocesses, real signals, a temp database."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from daq.store import Store

RIG = [sys.executable, "-m", "api.cli"]
ROOT = Path(__file__).resolve().parents[2]


def rig(*args: str, db: str, timeout: float = 60) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*RIG, *args, "--db", db], capture_output=True, text=True, timeout=timeout, cwd=ROOT
    )


@pytest.fixture
def db(tmp_path) -> str:
    return f"sqlite:///{tmp_path / 'rig.db'}"


def _wait_for_samples(db: str, count: int, timeout: float = 20) -> str:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        with Store(db) as store:
            runs = store.list_runs()
            if runs and store.sample_count(runs[0].id) >= count:
                return runs[0].id
        time.sleep(0.2)
    raise AssertionError(f"no run reached {count} samples in {timeout} s")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["tow", "--force", "-5"], "--force: -5.0 is not allowed (allowed 0 < --force ≤ 100 N"),
        (["tow", "--force", "nan"], "--force: nan is not allowed"),
        (["tow", "--force", "150"], "rig limit max_force_n"),
        (["tow", "--force", "10", "--weight", "1"], "give --force or --weight, not both"),
        (["spin", "--torque", "9"], "--torque: 9.0 is not allowed (allowed 0 < --torque ≤ 5 N·m"),
        (["tow", "--force", "10", "--rig", "fixtures/rigs/missing.toml"], "cannot read rig file"),
    ],
)
def test_bad_input_is_refused_and_writes_nothing(db, args, message):
    result = rig(*args, db=db)
    assert result.returncode == 2, result.stderr
    assert message in result.stderr
    with Store(db) as store:
        assert store.list_runs() == []


def test_bad_rig_file_names_the_field(db, tmp_path):
    text = (
        (ROOT / "fixtures/rigs/benbam.toml")
        .read_text()
        .replace('transport = "tcp"', 'transport = "udp"')
    )
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    result = rig("tow", "--force", "10", "--rig", str(bad), db=db)
    assert result.returncode == 2
    assert "modbus.transport: Input should be 'tcp' or 'rtu' (got 'udp')" in result.stderr


def test_sigkill_mid_run_leaves_an_interrupted_run_missing_at_most_a_second(db):
    proc = subprocess.Popen(
        [*RIG, "tow", "--force", "4.9", "--max-time", "120", "--db", db, "--json"], cwd=ROOT
    )
    try:
        run_id = _wait_for_samples(db, 25)
        time.sleep(0.7)
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


def test_sigterm_aborts_the_run_cleanly(db):
    proc = subprocess.Popen(
        [*RIG, "tow", "--force", "4.9", "--max-time", "120", "--db", db, "--json"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        text=True,
    )
    run_id = _wait_for_samples(db, 15)
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=20)
    assert proc.returncode == 1
    outcome = json.loads(out)
    assert outcome == outcome | {
        "run_id": run_id,
        "status": "aborted",
        "reason": "operator abort (SIGTERM)",
    }
    with Store(db) as store:
        assert store.get_run(run_id).status == "aborted"


def test_runs_show_export_import_round_trip(db, tmp_path):
    result = rig("tow", "--force", "44.1", "--max-time", "2", "--baseline", "0.3", "--json", db=db)
    assert result.returncode == 0, result.stderr
    run_id = json.loads(result.stdout)["run_id"]
    listed = json.loads(rig("runs", "--json", db=db).stdout)
    assert [r["id"] for r in listed] == [run_id]
    shown = json.loads(rig("show", run_id[:8], "--json", db=db).stdout)
    assert shown["status"] == "completed" and any(
        e["data"].get("action") == "release" for e in shown["events"] if e["data"]
    )
    csv_path = tmp_path / "run.csv"
    assert rig("export", run_id, "--format", "csv", "-o", str(csv_path), db=db).returncode == 0
    header = csv_path.read_text().splitlines()[0].split(",")
    assert header[0] == "t" and "tow_position" in header
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
