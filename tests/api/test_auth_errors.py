"""Token checks, 401/404/422 bodies and the OpenAPI document."""

from __future__ import annotations

import math

import pytest
from fastapi.testclient import TestClient

from api.http.app import create_app
from tests.api.conftest import AUTH, TOKEN

pytestmark = pytest.mark.usefixtures("imports_in_a_thread")


def test_health_needs_no_token_and_says_reads_are_protected(client):
    r = client.get("/api/health")
    assert r.status_code == 200
    assert r.json()["ok"] is True
    assert r.json()["read_requires_token"] is True


@pytest.mark.parametrize(
    ("method", "path"),
    [
        ("get", "/api/rig"),
        ("get", "/api/runs"),
        ("get", "/api/jobs"),
        ("get", "/api/results"),
        ("post", "/api/jobs/tow"),
        ("post", "/api/rig/arm"),
        ("post", "/api/estop/ack"),
        ("post", "/api/rig/hold"),
    ],
)
def test_every_endpoint_refuses_a_missing_or_wrong_token(client, method, path):
    missing = getattr(client, method)(path)
    assert missing.status_code == 401
    assert "rig token" in missing.json()["detail"]
    assert missing.headers["www-authenticate"] == "Bearer"
    wrong = getattr(client, method)(path, headers={"Authorization": "Bearer nope"})
    assert wrong.status_code == 401
    assert "wrong bearer token" in wrong.json()["detail"]


def test_open_read_lets_reads_through_but_never_writes(service, client):
    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with TestClient(app) as open_client:
        app.state.open_read = True
        assert open_client.get("/api/runs").status_code == 200
        assert open_client.get("/api/rig").status_code == 200
        assert open_client.get("/api/health").json()["read_requires_token"] is False
        assert open_client.post("/api/jobs/tow", json={"force_n": 5}).status_code == 401
        assert open_client.post("/api/rig/release").status_code == 401
        # the emergency stop needs no token at all (tests/api/test_people.py)


@pytest.mark.parametrize(
    ("body", "field", "allowed_has"),
    [
        ({"force_n": -150.0}, "force_n", "0 < |force_n| ≤ 100 N"),  # negative: a reverse tow
        ({"force_n": 0}, "force_n", "0 < |force_n|"),
        ({"force_n": 150.0}, "force_n", "max_force_n"),
        ({"force_n": "24.5"}, "force_n", "valid number"),
        ({"force_n": True}, "force_n", "valid number"),
        ({}, "force_n", "give force_n"),
        ({"force_n": 5.0, "weight_kg": 0.5}, "weight_kg", "not both"),
        ({"force_n": 5.0, "max_time_s": 9999}, "max_time_s", "max_time_s"),
        ({"force_n": 5.0, "max_distance_m": 9.0}, "max_distance_m", "end_of_travel_m"),
        ({"force_n": 5.0, "colour": "red"}, "colour", "Extra inputs"),
    ],
)
def test_bad_tow_parameters_are_422_naming_field_and_allowed_range(
    client, body, field, allowed_has
):
    r = client.post("/api/jobs/tow", json=body, headers=AUTH)
    assert r.status_code == 422, r.text
    problems = r.json()["errors"]
    assert field in [p["field"] for p in problems], problems
    problem = next(p for p in problems if p["field"] == field)
    assert allowed_has in problem["allowed"]
    assert field in r.json()["detail"]


def test_nan_and_infinity_are_refused_even_though_json_has_no_such_literal(client):
    for literal in ("NaN", "Infinity", "-Infinity"):
        r = client.post(
            "/api/jobs/tow",
            content=f'{{"force_n": {literal}}}',
            headers=AUTH | {"Content-Type": "application/json"},
        )
        assert r.status_code == 422, r.text
        (problem,) = r.json()["errors"]
        assert problem["field"] == "force_n"
        assert isinstance(problem["value"], str)  # a JSON-safe echo of the bad value
        assert not (isinstance(problem["value"], float) and math.isnan(problem["value"]))


def test_bad_spin_calibration_and_sequence_name_the_field(client):
    r = client.post("/api/jobs/spin", json={"torque_nm": 50.0}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "torque_nm"
    r = client.post("/api/jobs/calibration", json={"commands": [0.1, 2.0]}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "commands[1]"
    seq = {"steps": [{"kind": "tow", "force_n": 4.9}, {"kind": "spin", "torque_nm": 0}]}
    r = client.post("/api/jobs/sequence", json=seq, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "steps[1].torque_nm"


def test_unknown_ids_are_404_with_a_message(client):
    for path in (
        "/api/jobs/doesnotexist",
        "/api/runs/0123abcd",
        "/api/runs/0123abcd/samples",
        "/api/runs/0123abcd/samples.csv",
        "/api/runs/0123abcd/events",
        "/api/results/987654",
        "/api/results/987654/report/fit.png",
    ):
        r = client.get(path, headers=AUTH)
        assert r.status_code == 404, (path, r.text)
        assert r.json()["detail"]
    for action in ("abort", "pause", "resume", "confirm"):
        assert client.post(f"/api/jobs/nope/{action}", headers=AUTH).status_code == 404
    r = client.post("/api/jobs/estimation", json={"run_ids": ["0123abcd"]}, headers=AUTH)
    assert r.status_code == 404


def test_openapi_declares_errors_security_and_models(client):
    doc = client.get("/openapi.json").json()
    tow = doc["paths"]["/api/jobs/tow"]["post"]
    assert {"202", "401", "409", "422"} <= set(tow["responses"])
    assert tow["responses"]["422"]["content"]["application/json"]["schema"]["$ref"].endswith(
        "ErrorBody"
    )
    assert tow["security"] == [{"HTTPBearer": []}]
    assert "JobOut" in doc["components"]["schemas"]
    assert "text/csv" in doc["paths"]["/api/runs/import"]["post"]["requestBody"]["content"]


def test_cors_is_off_unless_an_origin_is_configured(service, client):
    preflight = {"Origin": "http://lab.example", "Access-Control-Request-Method": "POST"}
    r = client.options("/api/jobs/tow", headers=preflight)
    assert "access-control-allow-origin" not in r.headers
    app = create_app(
        service,
        token=TOKEN,
        manage_service=False,
        runner=client.app.state.runner,
        cors_origins=["http://lab.example"],
    )
    with TestClient(app) as cors_client:
        r = cors_client.options("/api/jobs/tow", headers=preflight)
        assert r.headers["access-control-allow-origin"] == "http://lab.example"
        r = cors_client.options(
            "/api/jobs/tow", headers=preflight | {"Origin": "http://evil.example"}
        )
        assert "access-control-allow-origin" not in r.headers
        refused = cors_client.post("/api/jobs/tow", headers={"Origin": "http://lab.example"})
        assert refused.status_code == 401  # refused before the body, with CORS headers
        assert refused.headers["access-control-allow-origin"] == "http://lab.example"


@pytest.mark.parametrize(
    ("path", "body"),
    [
        ("/api/jobs/tow", b'{"force_n": '),  # malformed JSON
        ("/api/jobs/tow", b'{"force_n": 0}'),  # well formed, invalid
        ("/api/runs/import?kind=tow&force_n=5&filename=..", b"t,position\n0,0\n"),
        ("/api/analysis/ahp", b"not json at all"),
        ("/api/runs/0123abcd/metadata", b"{"),  # PATCH below
    ],
)
def test_without_a_token_no_body_is_parsed_the_answer_is_401(client, path, body):
    method = "PATCH" if path.startswith("/api/runs/0") else "POST"
    headers = {"Content-Type": "application/json"}
    for auth in ({}, {"Authorization": "Bearer nope"}):
        r = client.request(method, path, content=body, headers=headers | auth)
        assert r.status_code == 401, r.text
        assert "token" in r.json()["detail"] and r.headers["www-authenticate"] == "Bearer"
    with_token = client.request(method, path, content=body, headers=headers | AUTH)
    assert with_token.status_code in (404, 422), with_token.text  # then the body is read


def test_every_answer_forbids_framing_and_the_ui_page_has_a_content_security_policy(client):
    page = client.get("/")
    assert page.status_code == 200
    policy = page.headers["content-security-policy"]
    assert "frame-ancestors 'none'" in policy and "script-src 'self'" in policy
    assert "default-src 'self'" in policy and "unsafe-eval" not in policy
    assert page.headers["x-frame-options"] == "DENY"
    assert page.headers["x-content-type-options"] == "nosniff"
    for path in ("/api/health", "/static/main.js", "/api/runs", "/docs"):
        r = client.get(path)
        assert "frame-ancestors 'none'" in r.headers["content-security-policy"], path
        assert r.headers["x-frame-options"] == "DENY", path


@pytest.mark.parametrize(
    "filename", ["..", ".", "../../etc/passwd", "/etc/passwd", "a/b.csv", "a\\b.csv", "..."]
)
def test_an_import_file_name_that_is_a_path_is_refused_naming_the_field(client, filename):
    r = client.post(
        "/api/runs/import",
        params={"kind": "tow", "force_n": 5, "filename": filename},
        content=b"t,position\n0,0\n0.1,0.01\n",
        headers=AUTH | {"Content-Type": "text/csv"},
    )
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith("filename: ")


def test_a_multipart_file_named_dot_dot_is_refused_and_a_path_keeps_only_its_name(client):
    upload = {"kind": "tow", "force_n": 5}
    csv = b"t,position\n0,0\n0.1,0.01\n0.2,0.03\n"
    r = client.post(
        "/api/runs/import", params=upload, files={"file": ("..", csv, "text/csv")}, headers=AUTH
    )
    assert r.status_code == 422, r.text
    assert "multipart part's filename" in r.json()["detail"]
    r = client.post(
        "/api/runs/import",
        params=upload,
        files={"file": ("../../lab/run-7.csv", csv, "text/csv")},
        headers=AUTH,
    )
    assert r.status_code == 201, r.text  # the client's folders are dropped, its name kept
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["source_file"] == "run-7.csv"
