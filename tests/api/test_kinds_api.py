"""``GET /api/kinds``: every kind of the registry with the JSON Schema its start route takes
(the one the route validates against, so a form rendered from it sends what the route
accepts) and its import fields; ``rig import`` offers the same kinds and fields."""

from __future__ import annotations

from typing import Annotated, ClassVar

import pytest
from click.testing import CliRunner
from pydantic import Field

from api.cli.imports import import_
from daq.config import load_rig
from daq.procedures.flag import Flag
from daq.procedures.kind_spec import KindSpec
from daq.procedures.procedure_request import MaxTime, ProcedureRequest, RigLimit
from daq.procedures.run_kinds import KINDS, RIG_KINDS
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind
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
    assert set(fields) == {
        "dof", "stiffness", "known_inertia", "stiffness_tolerance", "known_inertia_tolerance"
    }  # fmt: skip
    assert "heave" in fields["dof"]["anyOf"][0]["enum"]


def test_each_kind_serves_the_units_of_its_estimators_results(client):
    """``units``: per axis (or dof) an estimate may be on, what the result pages label its
    numbers with; tows and spins share the axis estimator, so both serve both axes."""
    served = {k["kind"]: k["units"] for k in client.get("/api/kinds", headers=AUTH).json()}
    surge = {
        "inertia": "kg", "linear_damping": "N·s/m", "quadratic_damping": "N·s²/m²",
        "damping_at_speed": "N·s/m", "position": "m", "velocity": "m/s",
    }  # fmt: skip
    assert served["tow"]["surge"] == surge and served["spin"] == served["tow"]
    yaw = served["spin"]["yaw"]
    assert (yaw["inertia"], yaw["damping_at_speed"], yaw["velocity"]) == (
        "kg·m²", "N·m·s/rad", "rad/s",
    )  # fmt: skip
    assert served["decay"]["heave"] == {"position": "m"}
    assert served["decay"]["roll"] == {"position": "rad"}
    assert served["pendulum"] == {} and served["thrust_calibration"] == {}


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


class _LiftRequest(ProcedureRequest):
    """A kind no face knows of: one signed load bounded by the rig (half its max_force_n)."""

    lift_n: Annotated[
        float | None,
        Field(title="Lift (N)", description="Lift, N."),
        Flag("--lift"),
        RigLimit(lambda rig: rig.limits.max_force_n / 2, signed=True),
    ] = None
    max_time_s: MaxTime = None

    kind: ClassVar[RunKind] = "lift"  # type: ignore[assignment]  # not a RunKind yet


@pytest.fixture
def lift_kind(monkeypatch):
    """A new rig kind in the registry, and nothing else edited."""
    spec = KindSpec(
        kind="lift",  # type: ignore[arg-type]
        rank=60,
        label="lift test",
        help="Lift.",
        request=_LiftRequest,
        route="lift",
        drives={"weight": Needs(), "thrusters": Needs(thrusters=True)},
        live=("lift_position", "load_cell"),
    )
    monkeypatch.setitem(KINDS, "lift", spec)
    monkeypatch.setitem(RIG_KINDS, "lift", spec)
    return spec


def test_the_rig_serves_each_kinds_field_limits_from_its_request_model(client, lift_kind):
    """``GET /api/rig`` → ``field_limits``: the limit each request model's ``RigLimit``
    declares, for every kind the rig runs (a new kind's too), nothing for an unbounded field."""
    rig = load_rig()
    limits, g = rig.limits, rig.rig.g
    served = client.get("/api/rig", headers=AUTH).json()["field_limits"]
    assert served["tow"] == {
        "force_n": {"max": limits.max_force_n, "min": -limits.max_force_n},
        "weight_kg": pytest.approx(
            {"max": limits.max_force_n / g, "min": -limits.max_force_n / g}, rel=1e-12
        ),
        "max_distance_m": {"max": rig.geometry.end_of_travel_m},
        "max_time_s": {"max": limits.max_run_s},
    }
    assert served["spin"]["torque_nm"] == {
        "max": limits.max_torque_nm,
        "min": -limits.max_torque_nm,
    }
    assert served["pendulum"] == {"max_time_s": {"max": limits.max_run_s}}
    assert served["thrust_calibration"] == {}
    half = limits.max_force_n / 2
    assert served["lift"] == {
        "lift_n": {"max": half, "min": -half},
        "max_time_s": {"max": limits.max_run_s},
    }


def test_a_new_kinds_rig_limit_reaches_its_start_form_without_other_edits(
    chromium, service, client, lift_kind
):
    """The page applies ``field_limits`` to whatever forms the registry rendered: the tow's
    force is −max…max, and a kind added only to the registry gets its declared limit."""
    from playwright.sync_api import expect

    from tests.api.conftest import signed_in_page

    served = client.get("/api/rig", headers=AUTH).json()["field_limits"]
    with signed_in_page(chromium, service, client) as page:
        lift = page.locator("#form-lift [name=lift_n]")
        expect(lift).to_have_attribute("max", f"{served['lift']['lift_n']['max']:g}")
        expect(lift).to_have_attribute("min", f"{served['lift']['lift_n']['min']:g}")
        force = page.locator("#form-tow [name=force_n]")
        expect(force).to_have_attribute("max", f"{served['tow']['force_n']['max']:g}")
        expect(force).to_have_attribute("min", f"{served['tow']['force_n']['min']:g}")
        weight = float(page.locator("#form-tow [name=weight_kg]").get_attribute("max") or "nan")
        assert weight == pytest.approx(served["tow"]["weight_kg"]["max"], rel=1e-12)
        assert page.locator("#form-calibration [name=settle_s]").get_attribute("max") is None


def test_the_live_plot_and_the_cross_check_read_the_served_kinds(
    chromium, service, client, lift_kind
):
    """The live plot's derived rates and default channels, the Runs page's kind filter and
    the cross-check's kinds come from ``GET /api/kinds``: idle, the first kind's (the tow's
    position and speed); a kind added to the registry only has its own ``live`` channels, is
    offered by the filter and, driven by a weight and by the thrusters, is cross-checked."""
    from playwright.sync_api import expect

    from tests.api.conftest import signed_in_page

    served = {k["kind"]: k for k in client.get("/api/kinds", headers=AUTH).json()}
    assert served["tow"]["rate"] == {
        "key": "speed", "label": "speed (from position)", "unit": "m/s", "of": "tow_position"
    }  # fmt: skip
    assert served["spin"]["live"] == ["yaw_angle", "yaw_rate"] and served["spin"]["axis"] == "yaw"
    assert served["spin"]["shown"] == {"field": "torque_nm", "unit": "N·m"}  # its drive
    assert served["pendulum"]["shown"] == {"field": "start_angle_rad", "unit": "rad"}
    # their envelopes: loads and travel (tow, spin), the releases the rig allows (pendulum)
    assert [k for k, v in served.items() if v["planned"]] == ["tow", "spin", "pendulum"]
    with signed_in_page(chromium, service, client) as page:
        chooser = page.locator("#live-channels")
        expect(chooser).to_contain_text("speed (from position) m/s")
        expect(chooser).to_contain_text("yaw rate (from angle) rad/s")
        expect(page.locator("#live-kind")).to_have_text("tow")
        checked = chooser.locator("input:checked")
        expect(checked).to_have_count(2)
        assert checked.evaluate_all("els => els.map((e) => e.value)") == ["tow_position", "speed"]
        assert page.evaluate("import('/static/live.js').then((m) => m.liveDefaultsOf('lift'))") == [
            "lift_position",
            "load_cell",
        ]
        driven = served["tow"]["live"] + served["spin"]["live"] + ["lift_position", "load_cell"]
        assert (
            page.evaluate("import('/static/live.js').then((m) => m.liveDefaultsOf('sequence'))")
            == driven
        )
        kinds = page.locator("#runs-filter select[name=kind] option")  # the Runs page's filter
        expect(kinds).to_have_count(len(served) + 1)
        assert kinds.all_text_contents() == ["any", *served]  # the free decay and lift too
        units = page.evaluate(
            "import('/static/start_forms.js').then((m) => m.axisUnits())"
        )  # the result pages' units, merged per axis
        assert units["yaw"] == served["spin"]["units"]["yaw"]  # the decay's adds, never drops
        assert units["roll"] == {"position": "rad"}
        cc = page.evaluate(
            "Promise.all([import('/static/crosscheck.js'), import('/static/start_forms.js')])"
            ".then(([cc, kinds]) => cc.crosscheckKinds(kinds.servedKinds))"
        )
        assert cc == {
            "kinds": ["tow", "spin", "lift"],
            "axes": ["surge", "yaw", None],
            "estimators": ["axis", "axis", None],
        }
