"""POST /api/calibrations/import and GET /api/thrust on the published T200 table: a
calibration stored without a run, the law's force and command with σ, and one-line 422s
naming the field (the column and line of a bad cell; the largest deliverable force)."""

from __future__ import annotations

from pathlib import Path
from urllib.parse import urlencode

from tests.api.conftest import AUTH

T200 = Path(__file__).resolve().parents[2] / "fixtures" / "calibrations" / "t200-bollard.csv"
QUERY = {
    "command_column": "PWM (µs)",
    "command_unit": "pwm_us",
    "thrust_column": "Force (Kg f)",
    "thrust_unit": "kgf",
    "voltage_column": "Voltage (V)",
    "name": "t200",
}


def _post(client, body: bytes, **query):
    return client.post(
        f"/api/calibrations/import?{urlencode(QUERY | query)}",
        content=body,
        headers=AUTH | {"Content-Type": "text/csv"},
    )


def test_import_then_ask_the_law_for_force_and_command(client):
    r = _post(client, T200.read_bytes())
    assert r.status_code == 201, r.text
    made = r.json()
    assert made["rows"] == 255
    assert made["law"]["identified"] and made["law"]["voltages_v"] == [10, 12, 16, 18, 20]
    listed = client.get("/api/calibrations", headers=AUTH).json()
    assert listed[0]["id"] == made["id"] and listed[0]["voltages_v"] == [10, 12, 16, 18, 20]

    at14 = client.get("/api/thrust?command=1&voltage_v=14", headers=AUTH).json()
    at18 = client.get("/api/thrust?command=1&voltage_v=18", headers=AUTH).json()
    assert at14["calibration"] == {
        "source": "imported",
        "id": made["id"],
        "name": "t200",
        "label": f"imported {made['id']} (t200)",
    }
    assert at14["voltage_source"] == "14 V, as given"
    named = client.get(f"/api/thrust?command=1&voltage_v=14&calibration={made['id']}",
                       headers=AUTH).json()  # fmt: skip
    assert named["calibration"] == at14["calibration"] and named["force_n"] == at14["force_n"]
    missing = client.get("/api/thrust?command=1&calibration=run:999999", headers=AUTH)
    assert missing.status_code == 404, missing.text
    assert "identified" in at14["voltage_law"]
    force14 = at14["force_n"]
    assert 0 < force14["std"] < 0.05 * force14["value"]
    # Published full thrust: 3.71 kgf at 12 V, 5.25 kgf at 16 V; 14 V lies between.
    assert 3.71 * 9.80665 < force14["value"] < 5.25 * 9.80665
    assert at18["force_n"]["value"] > force14["value"]

    back = client.get(
        f"/api/thrust?force_n={force14['value'] / 2}&voltage_v=14", headers=AUTH
    ).json()
    assert 0 < back["command"]["value"] < 1 and back["command"]["std"] > 0


def test_a_force_beyond_full_command_at_that_voltage_is_refused_naming_the_limit(client):
    assert _post(client, T200.read_bytes()).status_code == 201
    top = client.get("/api/thrust?command=1&voltage_v=12", headers=AUTH).json()["force_n"]
    r = client.get(f"/api/thrust?force_n={top['value'] * 1.05:.3f}&voltage_v=12", headers=AUTH)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail.startswith("force_n: got ")
    assert f"allowed: up to {top['value']:.4g} N forward at 12 V" in detail
    assert "\n" not in detail
    # The same force at 20 V is within reach.
    r = client.get(f"/api/thrust?force_n={top['value'] * 1.05:.3f}&voltage_v=20", headers=AUTH)
    assert r.status_code == 200


def test_a_force_below_the_smallest_calibrated_thrust_is_refused_naming_it(client):
    """At 10 V the table's smallest forward reading is 0.05 kgf at 1548 µs (1532 µs reads
    0): half of it is refused with that thrust and command; it and 0 N are answered."""
    assert _post(client, T200.read_bytes()).status_code == 201
    floor = 0.05 * 9.80665
    r = client.get(f"/api/thrust?force_n={floor / 2:.4f}&voltage_v=10", headers=AUTH)
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert detail.startswith(f"force_n: got {floor / 2:.4f} N, allowed: at least {floor:.4g} N")
    assert "the smallest calibrated thrust, command 0.12" in detail and "\n" not in detail
    r = client.get(f"/api/thrust?force_n=-{floor / 2:.4f}&voltage_v=10", headers=AUTH)
    assert r.status_code == 422 and "N reverse at 10 V" in r.json()["detail"]
    for ok in (floor * 1.001, 0.0):
        r = client.get(f"/api/thrust?force_n={ok:.4f}&voltage_v=10", headers=AUTH)
        assert r.status_code == 200, r.text


def test_bad_tables_and_questions_are_one_line_422s(client):
    bad = "PWM (µs);Voltage (V);Force (Kg f)\n1500;12;0\n1600;12;zero\n".encode()
    r = _post(client, bad)
    assert r.status_code == 422
    assert r.json()["detail"] == (
        "t200: line 3, column 'Force (Kg f)': got 'zero', allowed: a number"
    )
    r = _post(client, T200.read_bytes(), thrust_column="Thrust")
    assert r.status_code == 422 and "thrust_column: no column 'Thrust'" in r.json()["detail"]
    r = client.get("/api/thrust?command=0.5&force_n=3", headers=AUTH)
    assert r.status_code == 422 and r.json()["detail"] == "command or force_n: give exactly one"
    r = client.get("/api/thrust?command=2", headers=AUTH)
    assert r.status_code == 422


def test_an_imported_table_is_the_latest_calibration_and_the_law_says_which_voltage(client):
    made = _post(client, T200.read_bytes(), name="t200-latest").json()
    latest = client.get("/api/calibration/latest", headers=AUTH)
    assert latest.status_code == 200, latest.text
    body = latest.json()
    assert (body["source"], body["id"], body["label"]) == (
        "imported",
        made["id"],
        f"imported {made['id']} (t200-latest)",
    )
    assert body["run_ids"] == [] and len(body["data"]["table"]) == 255
    assert body["data"]["fit"]["parameters"]["forward_gain"]["value"] > 0
    listed = client.get("/api/calibrations", headers=AUTH).json()
    assert listed[0]["label"] == body["label"] and listed[0]["source"] == "imported"
    # No run of this module recorded a supply voltage: the calibration's reference is used,
    # and the answer says so.
    answer = client.get("/api/thrust?command=1", headers=AUTH).json()
    assert answer["voltage_v"] == 20
    assert answer["voltage_source"].startswith("20 V, the calibration's reference")


def test_a_pwm_table_imported_as_fractions_is_told_to_use_pwm_us(client):
    r = _post(client, T200.read_bytes(), command_unit="fraction")
    assert r.status_code == 422
    assert "looks like a PWM pulse in µs: use command_unit pwm_us" in r.json()["detail"]


def test_a_table_uploaded_as_a_multipart_form_imports(client):
    r = client.post(
        f"/api/calibrations/import?{urlencode(QUERY | {'name': 't200-form'})}",
        files={"file": ("t200-bollard.csv", T200.read_bytes(), "text/csv")},
        headers=AUTH,
    )
    assert r.status_code == 201, r.text
    assert r.json()["rows"] == 255
