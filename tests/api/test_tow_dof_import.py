"""A tow imported as another straight line (``rig import --kind tow --dof heave``, issue 31
item 4): the dof is stored with the run and every result text names it, never "surge"."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from estimation.data.run_arrays import RunData, validate_runs
from tests.api.conftest import AUTH
from tests.support.cli import RigCli
from tests.support.shared_data import shared_file

pytestmark = pytest.mark.usefixtures("imports_in_a_thread")

CSV = {"Content-Type": "text/csv"}
SPHERE = ("real", "tencate-sphere-settling", "tencate_E1_tow.csv")
WEIGHT_N = "0.0026004"  # the sphere's net weight (the record's README)


@pytest.fixture
def rig(tmp_path: Path) -> RigCli:
    cli = RigCli(tmp_path)
    cli.env.pop("RIG_FILE", None)
    return cli


def _estimate(rig: RigCli, run: str, folder: str) -> tuple[str, dict, str]:
    """The CLI's summary, the result document and report.md of one run's estimate."""
    summary = rig("estimate", run, "--report", folder).stdout
    doc = json.loads((rig.folder / folder / "result.json").read_text())
    return summary, doc, (rig.folder / folder / "report.md").read_text()


def test_a_settling_sphere_imported_as_heave_is_heave_in_every_text(rig) -> None:
    record = str(shared_file(*SPHERE))
    run = rig("import", record, "--kind", "tow", "--force", WEIGHT_N, "--dof", "heave")
    run_id = run.stdout.strip()
    shown = json.loads(rig("show", run_id, "--json").stdout)
    assert shown["parameters"]["dof"] == "heave"
    summary, doc, report = _estimate(rig, run_id, "rep")
    assert doc["dof"] == "heave"
    assert summary.splitlines()[0].startswith("heave tow test / output-error from 1 run(s)")
    assert report.splitlines()[0] == "# Estimation report — heave, output-error"
    assert "| heave, weight, +0.0026 N |" in report  # the repeats' condition
    listed = rig("results").stdout  # the stored result as `rig results` lists it
    assert "heave tow test / output-error" in listed
    texts = [summary, report, listed, *doc["warnings"], *doc["advice"]]
    assert not [t for t in texts if "surge" in t.lower()]


def test_a_tow_without_dof_is_imported_and_reported_as_surge_as_before(rig) -> None:
    record = str(shared_file(*SPHERE))
    run_id = rig("import", record, "--kind", "tow", "--force", WEIGHT_N).stdout.strip()
    assert "dof" not in json.loads(rig("show", run_id, "--json").stdout)["parameters"]
    summary, doc, report = _estimate(rig, run_id, "rep")
    assert "dof" not in doc and doc["axis"] == "surge"
    assert summary.splitlines()[0].startswith("surge tow test / output-error from 1 run(s)")
    assert report.splitlines()[0] == "# Estimation report — surge, output-error"


def test_the_cli_refuses_a_dof_a_tow_or_a_spin_cannot_have(rig) -> None:
    record = str(shared_file(*SPHERE))
    proc = rig("import", record, "--kind", "tow", "--force", WEIGHT_N, "--dof", "roll", code=2)
    assert proc.stderr == (
        "error: --dof: 'roll' is not allowed (allowed heave, surge, sway for a tow "
        "(default surge))\n"
    )
    proc = rig("import", record, "--kind", "spin", "--torque", "0.01", "--dof", "heave", code=2)
    assert proc.stderr == "error: --dof: 'heave' is not allowed (not used by a spin)\n"
    assert json.loads(rig("runs", "--json").stdout) == []  # nothing was imported


def test_the_api_refuses_a_bad_dof_and_an_export_keeps_a_good_one(client) -> None:
    body = shared_file(*SPHERE).read_bytes()
    query = f"/api/runs/import?kind=tow&force_n={WEIGHT_N}"
    r = client.post(f"{query}&dof=pitch", content=body, headers=AUTH | CSV)
    assert r.status_code == 422
    assert r.json()["detail"].startswith("dof: 'pitch' is not allowed")
    assert "heave, surge, sway" in r.json()["detail"]
    r = client.post(f"{query}&dof=heave", content=body, headers=AUTH | CSV)
    assert r.status_code == 201, r.text
    exported = client.get(f"/api/runs/{r.json()['run_id']}/export?format=csv", headers=AUTH)
    r = client.post("/api/runs/import?filename=out.csv", content=exported.content,
                    headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    assert r.json()["from_header"]["dof"] == "heave"
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["dof"] == "heave"


def _run(run_id: str, dof: str | None) -> RunData:
    t = np.linspace(0.0, 2.0, 21)
    return RunData(run_id, "surge", t, 0.01 * t**2, 1.0, dof=dof)


def test_runs_of_different_dofs_are_not_fitted_together() -> None:
    assert validate_runs([_run("a", "heave"), _run("b", "heave")]) == "surge"
    with pytest.raises(ValueError, match=r"dof: got mixed dofs \['heave', 'surge'\]"):
        validate_runs([_run("a", "heave"), _run("b", None)])
    with pytest.raises(ValueError, match=r"run 'a': dof: got 'roll', allowed: heave, surge"):
        validate_runs([_run("a", "roll")])


def test_a_heave_tow_result_is_plugged_into_the_vehicles_heave_not_its_surge() -> None:
    from estimation.vehicle.apply_estimates import apply_result_json
    from estimation.vehicle.vehicle_file import load_vehicle

    vehicle = load_vehicle(Path(__file__).resolve().parents[2] / "fixtures/vehicles/benbam.toml")
    doc = {
        "axis": "surge",
        "dof": "heave",
        "coefficients": {
            "inertia": {"value": 300.0, "std": 4.0},
            "linear_damping": {"value": 20.0, "std": 1.0},
            "quadratic_damping": {"value": 50.0, "std": 2.0},
        },
    }
    plugged = apply_result_json(vehicle, doc, "result 1")
    assert plugged.total_inertia("heave") == pytest.approx(300.0)
    assert plugged.coefficients()["linear_damping.heave"] == pytest.approx(20.0)
    assert plugged.total_inertia("surge") == pytest.approx(vehicle.total_inertia("surge"))
