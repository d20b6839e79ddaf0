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


def test_the_rig_pages_start_forms_are_rendered_from_the_served_schemas(chromium, service, client):
    """One tab and one form per kind the rig runs; every field of the schema (but the
    metadata block's) is an input of that name, labelled by its title; a new field of a
    request model appears without touching the page (the spin's max_angle_rad was never in
    the hand-written form)."""
    from playwright.sync_api import expect

    from tests.api.conftest import signed_in_page

    kinds = [k for k in client.get("/api/kinds", headers=AUTH).json() if k["schema"]]
    with signed_in_page(chromium, service, client) as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        expect(page.locator("#start-tabs button")).to_have_count(len(kinds))
        for kind in kinds:
            form = page.locator(f"#form-{kind['route']}")
            names = form.locator("[name]").evaluate_all("els => els.map((e) => e.name)")
            fields = [n for n in kind["schema"]["properties"] if n != "metadata"]
            assert names == fields, (kind["kind"], names)
            for name in fields:
                title = kind["schema"]["properties"][name]["title"]
                expect(form.locator(f"label:has([name={name}])")).to_contain_text(title)
        page.click("#start-tabs button[data-form=spin]")
        expect(page.locator("#form-spin [name=max_angle_rad]")).to_be_visible()
        expect(page.locator("#form-tow")).to_be_hidden()
        options = page.locator("#form-tow select[name=drive] option").all_text_contents()
        assert options == ["weight", "thrusters"]
        assert page.locator("#form-calibration [name=reverse]").is_checked()
        assert errors == []


def test_the_estimation_pages_method_menu_is_rendered_from_the_served_methods(
    chromium, service, client
):
    """Every method a served kind's estimator takes is one entry of the menu, in the served
    order (the default first), worded by its estimator's method_labels: a new estimator's
    methods appear without touching the page."""
    from playwright.sync_api import expect

    from tests.api.conftest import signed_in_page

    served: dict[str, str] = {}
    for kind in client.get("/api/kinds", headers=AUTH).json():
        for method in kind["methods"]:
            served.setdefault(method, kind["method_labels"].get(method, method))
    assert {"output-error", "ls-raw", "damped-fit"} <= set(served)
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=estimation]")
        menu = page.locator("#est-method option")
        expect(menu).to_have_count(len(served))
        assert menu.evaluate_all("os => os.map((o) => o.value)") == list(served)
        assert menu.all_text_contents() == list(served.values())
        assert page.locator("#est-method").input_value() == "output-error"
