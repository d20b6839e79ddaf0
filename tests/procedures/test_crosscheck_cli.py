"""`rig crosscheck` and `rig tow --thrusters` as an operator runs them (the tows as real
subprocesses, the cross-check of stored runs in this process: tests/procedures/test_cli.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from daq.csv_to_store import import_csv
from daq.store import Store
from tests.estimation.synth import SURGE_TRUTH, Physics, weight_run
from tests.procedures.test_cli import rig

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)


def _import_tows(store: Store, tmp_path, forces, seed: int) -> list[str]:
    ids = []
    rng = np.random.default_rng(seed)
    for force in forces:
        run = weight_run(
            Physics(*SURGE_TRUTH), force, rng=rng, baseline_s=0.0, duration_s=6.0, jitter_s=0.0
        )
        path = tmp_path / f"tow-{seed}-{force:g}.csv"
        rows = "\n".join(f"{t:.4f},{x:.4f}" for t, x in zip(run.t, run.position, strict=True))
        path.write_text("t,position\n" + rows + "\n", encoding="utf-8")
        ids.append(
            import_csv(
                store,
                path,
                kind="tow",
                parameters={"force_n": force, "hung_mass_kg": run.hung_mass_kg},
            )
        )
    return ids


@pytest.fixture
def stored(tmp_path):
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    with Store(db) as store:
        first = _import_tows(store, tmp_path, (24.5, 83.3), seed=1)
        second = _import_tows(store, tmp_path, (34.3, 63.7), seed=2)
    return db, first, second


def test_crosscheck_runs_then_stored_results(stored, tmp_path):
    db, first, second = stored
    report = tmp_path / "report"
    args = ["crosscheck"]
    for r in first:
        args += ["--weight", r]
    for r in second:
        args += ["--thrusters", r]
    args += ["--json", "--report", str(report)]
    done = rig(*args, db=db, timeout=120)
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert doc["axis"] == "surge" and doc["verdict"] in ("agree", "marginal", "disagree")
    # Same vehicle, same drive: the two sets agree to well within a per cent.
    for name, c in doc["coefficients"].items():
        assert abs(c["difference"]) < 0.01 * c["weight"]["value"] + 0.5, name
    assert (report / "report.md").read_text(encoding="utf-8").startswith("# Cross-check, surge")
    assert (report / "crosscheck.png").stat().st_size > 5000
    assert (report / "weight").is_dir() and (report / "thrusters").is_dir()
    with Store(db) as store:
        assert store.result(doc["result_id"]).kind == "crosscheck"
        assert set(store.result(doc["result_id"]).run_ids) == set(first + second)

    done = rig(
        "crosscheck",
        "--weight-result",
        str(doc["weight_result_id"]),
        "--thruster-result",
        str(doc["thruster_result_id"]),
        db=db,
    )
    assert done.returncode == 0, done.stderr
    assert "inertia" in done.stdout and "verdict:" in done.stdout and "diagnosis:" in done.stdout
    assert "stored as result #" in done.stdout


def test_crosscheck_input_errors(stored):
    db, first, _ = stored
    done = rig("crosscheck", "--weight", first[0], db=db)
    assert done.returncode == 2 and "give at least one run of each" in done.stderr
    done = rig("crosscheck", "--weight-result", "999", "--thruster-result", "1", db=db)
    assert done.returncode == 2
    assert "--weight-result: 999 is not allowed" in done.stderr  # the flag, not the field
    done = rig("crosscheck", "--weight-result", "1", "--weight", first[0], db=db)
    assert done.returncode == 2 and "not both" in done.stderr


def test_thruster_tow_without_a_calibration_is_refused(tmp_path):
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    done = rig("tow", "--thrusters", "--force", "20", db=db)
    assert done.returncode == 2
    assert "calibrate-thrusters" in done.stderr
    done = rig("tow", "--thrusters", "--weight", "2", db=db)
    assert done.returncode == 2
    assert "--weight: 2.0 is not allowed (a thruster-driven tow takes --force)" in done.stderr
