"""``rig import`` and ``POST /api/runs/import`` apply the same import rules
(``api.core.imports``): a load over the rig file's limit or against the motion is one
line naming the flag or query parameter, a one-row file is refused, a release before the
first sample is taken, and an export imports back from its own header."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE
from tests.api.conftest import AUTH, how_it_ended, wait_job
from tests.support.cli import RigCli
from tests.support.shared_data import shared_file

pytestmark = pytest.mark.usefixtures("imports_in_a_thread")

CSV = {"Content-Type": "text/csv"}


def _tow(path: Path, direction: float = 1.0) -> bytes:
    """60 samples at 10 Hz: still for 1 s, then accelerating the ``direction`` way."""
    t = np.arange(60) * 0.1
    x = direction * 0.05 * np.clip(t - 1.05, 0.0, None) ** 2
    path.write_text(
        "t,position\n" + "".join(f"{a:.1f},{b:.6f}\n" for a, b in zip(t, x, strict=True))
    )
    return path.read_bytes()


@pytest.fixture
def rig(tmp_path: Path) -> RigCli:
    _tow(tmp_path / "tow.csv")
    (tmp_path / "one.csv").write_text("t,position\n0,0\n")
    shutil.copy(DEFAULT_RIG_FILE, tmp_path / "rig.toml")
    cli = RigCli(tmp_path)
    cli.env.pop("RIG_FILE", None)
    return cli


def _error(rig: RigCli, *argv: str) -> str:
    proc = rig("import", *argv, code=2)
    assert proc.stderr.count("\n") == 1, proc.stderr
    return proc.stderr


def test_the_cli_refuses_what_the_file_or_the_rig_contradicts(rig) -> None:
    assert _error(rig, "tow.csv", "--kind", "tow", "--force", "-1e6", "--rig", "rig.toml") == (
        "error: --force: -1000000.0 is not allowed (allowed 0 < |--force| ≤ 100 N, rig limit "
        "max_force_n; negative for a reverse run)\n"
    )
    assert _error(rig, "tow.csv", "--kind", "tow", "--force", "-24.5").startswith(
        "error: --force: -24.5 is not allowed: the record first moves the positive way"
    )
    assert "a header but 1 data row" in _error(rig, "one.csv", "--kind", "tow", "--force", "1")
    assert _error(
        rig, "tow.csv", "--kind", "tow", "--force", "1", "--release-time", "-9"
    ).startswith("error: --release-time: -9.0 is not allowed; use a time within [-5.9, 5.9] s")
    assert json.loads(rig("runs", "--json").stdout) == []  # nothing was imported


def test_the_cli_imports_its_own_export_back_without_restating_it(rig, tmp_path) -> None:
    first = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5", "--weight", "2.5",
                "--release-time", "1.05", "--vehicle", "BENBAM-2").stdout.strip()  # fmt: skip
    rig("export", first, "-o", "out.csv")
    proc = rig("import", "out.csv", "--json")
    assert proc.stderr.startswith("note: from the file's header: kind tow, force_n 24.5")
    again = json.loads(proc.stdout)["run_id"]
    run = json.loads(rig("show", again, "--json").stdout)
    assert (run["kind"], run["vehicle"], run["drive"]) == ("tow", "BENBAM-2", "weight")
    assert run["parameters"]["force_n"] == 24.5 and run["parameters"]["hung_mass_kg"] == 2.5
    assert run["parameters"]["release_time_s"] == pytest.approx(1.05)
    early = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5", "--release-time", "-0.5")
    shown = json.loads(rig("show", early.stdout.strip(), "--json").stdout)
    assert shown["parameters"]["release_time_s"] == pytest.approx(-0.5)


def test_the_api_applies_the_same_rules(client, tmp_path) -> None:
    body = _tow(tmp_path / "tow.csv")
    r = client.post("/api/runs/import?kind=tow&force_n=-24.5", content=body, headers=AUTH | CSV)
    assert r.status_code == 422
    assert r.json()["detail"].startswith("force_n: -24.5 is not allowed: the record first moves")
    r = client.post("/api/runs/import?kind=tow&force_n=1", content=b"t,position\n0,0\n",
                    headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 422 and "a header but 1 data row" in r.json()["detail"]
    r = client.post("/api/runs/import?force_n=1", content=body, headers=AUTH | CSV)
    assert r.status_code == 422 and r.json()["detail"].startswith("kind: missing is not allowed")

    r = client.post("/api/runs/import?kind=tow&force_n=24.5&weight_kg=2.5&release_time_s=1.05",
                    content=body, headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    exported = client.get(f"/api/runs/{r.json()['run_id']}/export?format=csv", headers=AUTH)
    r = client.post("/api/runs/import?filename=out.csv", content=exported.content,
                    headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    assert r.json()["from_header"] == {"kind": "tow", "force_n": 24.5, "hung_mass_kg": 2.5,
                                       "release_time_s": pytest.approx(1.05),
                                       "vehicle": "unknown"}  # fmt: skip
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["hung_mass_kg"] == 2.5
    r = client.post("/api/runs/import?kind=spin", content=exported.content, headers=AUTH | CSV)
    assert r.status_code == 422
    assert r.json()["detail"].startswith("kind: 'spin' disagrees with the file's header")


def test_the_sphere_settling_record_takes_its_release_before_the_first_sample(rig) -> None:
    """The README's command for ten Cate's sphere, released at t = 0 and first sampled
    0.084 s later: `--release-time 0` was refused ("use a time within the file's t range")."""
    record = shared_file("real", "tencate-sphere-settling", "tencate_E1_tow.csv")
    run = rig("import", str(record), "--kind", "tow", "--force", "0.0026004",
              "--release-time", "0", "--end-time", "2.45").stdout.strip()  # fmt: skip
    parameters = json.loads(rig("show", run, "--json").stdout)["parameters"]
    assert parameters["release_time_s"] == pytest.approx(-0.08443)
    assert parameters["end_time_s"] == pytest.approx(2.45 - 0.08443)


def test_a_foreign_csv_that_names_its_vehicle_imports_as_that_vehicle(rig, client, tmp_path):
    """Another tool's CSV naming the vehicle in a leading comment (``# vehicle: NAME``, any
    case, ':' or '='; or its ``# metadata:`` line) is that vehicle's run, not 'unknown'."""
    rows = (tmp_path / "tow.csv").read_text()
    (tmp_path / "named.csv").write_text("# logged by tank-daq 2.1\n# Vehicle = ROV-7\n" + rows)
    ran = rig("import", "named.csv", "--kind", "tow", "--force", "24.5", "--json")
    assert "vehicle ROV-7" in ran.stderr
    shown = json.loads(rig("show", json.loads(ran.stdout)["run_id"], "--json").stdout)
    assert shown["vehicle"] == "ROV-7"
    stated = rig("import", "named.csv", "--kind", "tow", "--force", "24.5", "--vehicle", "X2")
    assert json.loads(rig("show", stated.stdout.strip(), "--json").stdout)["vehicle"] == "X2"
    plain = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5")
    assert json.loads(rig("show", plain.stdout.strip(), "--json").stdout)["vehicle"] == "unknown"

    # Over HTTP: Excel's BOM and ';' with decimal commas, the vehicle in the metadata line.
    body = '\ufeff# metadata: {"vehicle": "Sphere E1"}\n' + rows.replace(",", ";").replace(".", ",")
    r = client.post("/api/runs/import?kind=tow&force_n=24.5", content=body.encode(),
                    headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    assert r.json()["from_header"] == {"vehicle": "Sphere E1"}
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["vehicle"] == "Sphere E1"


#: The _tow record's inertia: 24.5 N accelerating it at 0.1 m/s² (no damping in it).
TOW_INERTIA_KG = 245.0
BELOW_OWN = "is below the body's own"


def test_a_declared_dry_mass_above_the_fitted_inertia_is_flagged(rig, client, tmp_path):
    """An import's declared dry mass (or displacement) reaches the estimator as the body's
    own inertia: an inertia identified below it is flagged as not physical, through the CLI
    and through HTTP; one below the fitted inertia is not."""
    heavy = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5", "--dry-mass", "300")
    out = json.loads(rig("estimate", heavy.stdout.strip(), "--json").stdout)
    assert out["coefficients"]["inertia"]["value"] == pytest.approx(TOW_INERTIA_KG, rel=0.05)
    assert any(BELOW_OWN in w and "300" in w for w in out["warnings"]), out["warnings"]
    light = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5", "--dry-mass", "100")
    out = json.loads(rig("estimate", light.stdout.strip(), "--json").stdout)
    assert not any(BELOW_OWN in w for w in out["warnings"])
    assert "--dry-mass: -3.0 is not allowed" in _error(
        rig, "tow.csv", "--kind", "tow", "--force", "24.5", "--dry-mass", "-3"
    )

    body = (tmp_path / "tow.csv").read_bytes()
    r = client.post("/api/runs/import?kind=tow&force_n=24.5&displacement_kg=280",
                    content=body, headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["displacement_kg"] == 280.0
    r = client.post("/api/jobs/estimation", json={"run_ids": [run["id"]]}, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)
    assert job["state"] == "completed", how_it_ended(job)
    assert any(BELOW_OWN in w and "280" in w for w in job["outcome"]["warnings"])
    r = client.post("/api/runs/import?kind=spin&torque_nm=2&dry_mass_kg=30", content=body,
                    headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 422 and r.json()["detail"].startswith("dry_mass_kg: 30.0 is not")
