"""``GET /api/kinds``: every kind of the registry with the JSON Schema its start route takes
(the one the route validates against, so a form rendered from it sends what the route
accepts) and its import fields; ``rig import`` offers the same kinds and fields."""

from __future__ import annotations

from click.testing import CliRunner

from api.cli.imports import import_
from daq.procedures.kinds import KINDS
from tests.api.conftest import AUTH


def test_every_kind_is_served_with_its_request_schema_and_import_fields(client):
    r = client.get("/api/kinds", headers=AUTH)
    assert r.status_code == 200, r.text
    served = {k["kind"]: k for k in r.json()}
    assert list(served) == [str(k) for k in KINDS]
    tow = served["tow"]
    assert tow["route"] == "tow" and tow["command"] == "tow" and tow["label"] == "tow test"
    props = tow["schema"]["properties"]
    assert {"force_n", "weight_kg", "drive", "max_distance_m", "baseline_s"} <= set(props)
    assert props["drive"]["enum"] == ["weight", "thrusters"]
    assert tow["schema"]["additionalProperties"] is False
    assert "output-error" in tow["methods"] and tow["estimator"] == "axis"
    cal = served["thrust_calibration"]
    assert cal["import"] is None and cal["estimator"] is None
    assert cal["schema"]["properties"]["commands"]["anyOf"][0]["maxItems"] == 50
    decay = served["decay"]
    assert decay["schema"] is None and decay["route"] is None  # imported, not run on the rig
    assert decay["methods"] == ["output-error"]
    fields = decay["import"]["schema"]["properties"]
    assert set(fields) == {"dof", "stiffness", "known_inertia"}
    assert "heave" in fields["dof"]["anyOf"][0]["enum"]


def test_a_served_schema_is_the_body_the_route_validates(client):
    schema = client.get("/api/kinds", headers=AUTH).json()[0]["schema"]
    assert "colour" not in schema["properties"]
    r = client.post("/api/jobs/tow", json={"force_n": 5.0, "colour": "red"}, headers=AUTH)
    assert r.status_code == 422 and r.json()["errors"][0]["field"] == "colour"


def test_rig_import_offers_the_registrys_kinds_and_their_fields():
    text = CliRunner().invoke(import_, ["--help"], terminal_width=200).output
    for kind, spec in KINDS.items():
        assert (kind in text) == (spec.imports is not None), kind
    assert "--dof [surge|sway|heave|roll|pitch|yaw]" in text and "--stiffness" in text
