"""Theory beside measurement through the faces: ``rig predict-added-mass``, ``rig water``,
GET /api/vehicles/{name}/added-mass and GET /api/water. BENBAM's hull (a spheroid of its
30 kg displacement) against the vehicle file's seed-000 surge added mass of 113 kg."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from api.cli.theory import predict_added_mass, water
from tests.api.conftest import AUTH

pytestmark = pytest.mark.simtime  # the stored estimate comes from a tow (tow_job)


def test_cli_flags_benbams_surge_added_mass():
    result = CliRunner().invoke(predict_added_mass, ["benbam", "--water-temp", "20"])
    assert result.exit_code == 0, result.output
    surge = next(line for line in result.output.splitlines() if line.startswith("surge"))
    assert "113.3" in surge and "OUTSIDE" in surge
    assert "usual causes: drive-train inertia" in result.output
    assert "ρ 998.21 kg/m³" in result.output


def test_cli_json_has_per_dof_prediction_verdict_and_blockage():
    args = ["benbam", "--tank-width", "1.2", "--water-depth", "1.0", "--json"]
    result = CliRunner().invoke(predict_added_mass, args)
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    rows = {row["dof"]: row for row in out["dofs"]}
    # A 1 m × 0.2396 m spheroid (L/D 4.17): k1 ≈ 0.077 of its ≈ 30 kg displacement.
    assert rows["surge"]["predicted"] == pytest.approx(2.3, abs=0.1)
    assert rows["surge"]["verdict"]["plausible"] is False
    assert rows["roll"]["verdict"] is None  # a body of revolution adds nothing in roll
    assert out["blockage"]["exceeds"] is True
    assert out["water"]["temperature_c"] == 15.0


def test_cli_water():
    result = CliRunner().invoke(water, ["--temp", "10"])
    assert result.exit_code == 0, result.output
    assert "ρ = 999.70" in result.output and "ν = 1.3063e-06 m²/s" in result.output


def test_cli_water_with_a_speed_gives_reynolds_and_froude():
    """Seed 000's fastest steady tow, 0.51 m/s, over BENBAM's placeholder 1 m at 15 °C."""
    args = ["--temp", "15", "--speed", "0.51", "--length", "1", "--g", "9.8", "--json"]
    result = CliRunner().invoke(water, args)
    assert result.exit_code == 0, result.output
    flow = json.loads(result.output)["flow"]
    assert flow["reynolds"] == pytest.approx(0.51 / 1.1386e-6, rel=1e-4)
    assert flow["froude"] == pytest.approx(0.51 / 9.8**0.5)


def test_http_added_mass_and_water(client):
    r = client.get("/api/vehicles/benbam/added-mass?water_temp_c=20", headers=AUTH)
    assert r.status_code == 200, r.text
    out = r.json()
    surge = next(row for row in out["dofs"] if row["dof"] == "surge")
    assert surge["value"] == pytest.approx(113.26)
    assert surge["verdict"]["ratio"] > 40
    assert out["blockage"] is None
    w = client.get("/api/water?temp_c=15", headers=AUTH).json()
    assert w["density_kg_m3"] == pytest.approx(999.1026, abs=5e-4)


@pytest.mark.parametrize(
    ("url", "code", "text"),
    [
        ("/api/vehicles/seed002-rov/added-mass", 422, "hull: got None"),
        ("/api/vehicles/nope/added-mass", 404, "no vehicle named 'nope'"),
        ("/api/vehicles/benbam/added-mass?tank_width_m=2", 422, "both or neither"),
        ("/api/vehicles/benbam/added-mass?water_temp_c=80", 422, "water_temp_c"),
        ("/api/water?temp_c=-1", 422, "temp_c"),
        ("/api/water?temp_c=15&speed_m_s=1", 422, "both or neither"),
    ],
)
def test_http_errors_name_the_field(client, url, code, text):
    r = client.get(url, headers=AUTH)
    assert r.status_code == code, r.text
    assert text in r.text
    assert client.get(url).status_code == 401  # reads need the token


def test_http_compares_a_stored_estimate(client, tow_job):
    """A stored surge result of m + m_a = 32.5 kg (30 kg body): 2.5 kg measured against
    ≈ 2.3 kg predicted, within the band, and the row says where the value came from."""
    store = client.app.state.service.store
    doc = {
        "axis": "surge",
        "coefficients": {
            "inertia": {"value": 32.5, "std": 0.5},
            "linear_damping": {"value": 20.0, "std": 1.0},
            "quadratic_damping": {"value": 40.0, "std": 2.0},
        },
    }
    result_id = store.add_result(tow_job["run_ids"], "estimation", doc)
    r = client.get(f"/api/vehicles/benbam/added-mass?estimates={result_id}", headers=AUTH)
    assert r.status_code == 200, r.text
    surge = next(row for row in r.json()["dofs"] if row["dof"] == "surge")
    assert surge["source"] == f"result {result_id}"
    assert surge["value"] == pytest.approx(2.5)
    assert surge["sigma"] == pytest.approx(0.5)
    assert surge["verdict"]["plausible"] is True
    missing = client.get("/api/vehicles/benbam/added-mass?estimates=999999999", headers=AUTH)
    assert missing.status_code == 404


def test_the_theory_comparison_takes_the_runs_recorded_salinity(tmp_path):
    """A sea-water tank's runs (salinity recorded with them, ``--salinity``) are compared in
    sea water: ρ from the temperature and the salinity, not fresh water's; runs without it
    are fresh water at their recorded or ITTC's 15 °C."""
    from api.core.theory_job import water_of_runs
    from daq.store import Store
    from estimation.water import water_properties
    from tests.store.helpers import new_run

    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    sea = [new_run(store) for _ in range(2)]
    for rid, temp in zip(sea, (19.0, 21.0), strict=True):
        store.set_run_metadata(rid, {"water_temperature_c": temp, "salinity_g_kg": 35.165})
    temp, salinity, source = water_of_runs([store.get_run(rid) for rid in sea])
    assert (temp, salinity) == (20.0, 35.165) and "salinity from run metadata" in source
    assert water_properties(temp, salinity).density == pytest.approx(1024.8, abs=0.1)
    fresh = water_of_runs([store.get_run(new_run(store))])
    assert fresh[:2] == (15.0, 0.0) and "fresh water" in fresh[2]
    store.close()


def test_runs_recorded_in_water_the_model_does_not_cover_are_not_compared(tmp_path):
    """A tank at 45 °C (the metadata allows up to 50 °C; the water formulas cover 0–40 °C):
    the estimate says why it has no theory comparison instead of failing in its middle."""
    from api.core.theory_job import theory_document
    from daq.store import Store
    from tests.store.helpers import BENBAM_TOML, new_run

    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    rid = new_run(store, rig_toml=BENBAM_TOML)
    store.set_run_metadata(rid, {"water_temperature_c": 45.0})
    budget = {"coefficients": {}, "tolerances": {}}
    result = {"axis": "surge", "budget": budget, "runs": [rid]}
    doc = theory_document([store.get_run(rid)], result, None)
    missing = doc["theory"]["missing"]
    assert "outside the water model" in missing and "temperature_c: got 45.0" in missing
    store.close()
