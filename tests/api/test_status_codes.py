"""The documented status codes, walked: every operation of the OpenAPI document is in
docs/api.md's endpoint table, every code a table row names is declared on its route
(``responses=``), and every code the app answers here is a declared one.

Each operation is sent what draws the codes reachable in process without a real fault: no
token (401), a viewer's token where an operator's is needed (403), ids nothing has (404),
a body or query parameter that is not what the route takes (422), a body over its cap
(413), and a service that is not running (503, a second app whose service never started);
then a few states by hand (409: an acknowledgement with no emergency stop latched; 423: a
start while another user holds the rig). The emergency stop itself is not sent (it stops
the module's rig; ``tests/api/test_people.py`` covers it).
"""

from __future__ import annotations

import contextlib
import re
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from api.core.service import RigService
from api.http.app import create_app
from daq.session import RigSource
from daq.store.migrate import create_engine
from daq.store.people_and_safety_log import UserRepository
from tests.api.conftest import AUTH, TOKEN, wait_rig_free

pytestmark = pytest.mark.simtime

DOCS = Path(__file__).resolve().parents[2] / "docs" / "api.md"
#: The codes a docs row may name (a bare 200 is every success's; numbers like "≤ 100"
#: are not codes).
CODES = ("201", "202", "204", "400", "401", "403", "404", "409", "413", "415", "422", "423",
         "503")  # fmt: skip
#: An id no run, result, job or vehicle has (well-formed, so the lookup answers, not the
#: parser).
UNKNOWN = {"run_id": "0" * 32, "result_id": "999999", "job_id": "999999", "name": "no-such"}
#: Not sent: stops the module's rig (covered in tests/api/test_people.py).
NOT_SENT = {("post", "/api/rig/emergency-stop")}
OVER_CAP = b"x" * (70 * 1024)  # the test app caps JSON bodies and uploads at 64 KiB


def _norm(path: str) -> str:
    """``/api/jobs/{job_id}/abort`` and ``/jobs/{id}/abort`` alike: ``/jobs/{}/abort``."""
    return re.sub(r"\{[^}]*\}", "{}", path.removeprefix("/api"))


def _documented() -> dict[tuple[str, str], set[str]]:
    """(method, normalised path) → the codes its docs/api.md table row names."""
    out: dict[tuple[str, str], set[str]] = {}
    for row in DOCS.read_text(encoding="utf-8").splitlines():
        if not row.startswith("| `"):
            continue
        first = row.split(" | ")[0]
        codes = set(re.findall(r"(?<![\d.])(\d{3})(?![\d.])", row)) & set(CODES)
        method = None
        for verb, path in re.findall(r"`(?:(GET|POST|PUT|PATCH|DELETE) )?(/[^`?\[\s]*)", first):
            if verb:
                method, base = verb.lower(), path
            elif method is None:
                continue
            else:  # "`POST /jobs/{id}/pause`, `/resume`": a sibling of the path before
                path = base.rsplit("/", 1)[0] + path
            out.setdefault((method, _norm(path)), set()).update(codes)
    return out


def _operations(app) -> list[tuple[str, str, dict[str, Any]]]:
    spec = app.openapi()
    return [(m, p, op) for p, ops in spec["paths"].items() for m, op in ops.items()]


def _url(path: str) -> str:
    return path.format(**{**UNKNOWN, "name": UNKNOWN["name"]}).replace(
        "/report/no-such.", "/report/fit."
    )


def _has_body(op: dict[str, Any]) -> bool:
    return "requestBody" in op


def _csv_body(op: dict[str, Any]) -> bool:
    return "text/csv" in op.get("requestBody", {}).get("content", {})


def _send(client: TestClient, method: str, url: str, headers: dict, body: Any = None, **kw):
    if isinstance(body, bytes):
        return client.request(method, url, content=body, headers=headers, **kw)
    return client.request(method, url, json=body, headers=headers, **kw)


def _bad_query(op: dict[str, Any]) -> dict[str, str] | None:
    """A value the first typed query parameter refuses (None: no such parameter)."""
    for p in op.get("parameters", []):
        schema = p.get("schema", {})
        kinds = {s.get("type") for s in schema.get("anyOf", [schema])}
        if p["in"] == "query" and kinds & {"integer", "number"}:
            return {p["name"]: "not-a-number"}
    return None


@pytest.fixture(scope="module")
def viewer(service, client) -> dict[str, str]:
    return {"Authorization": f"Bearer {UserRepository(service.store).add('vee', 'viewer')}"}


@pytest.fixture(scope="module")
def stopped(tmp_path_factory):
    """A client of an app whose service never started (no database, no rig)."""
    db = tmp_path_factory.mktemp("stopped") / "rig.db"
    app = create_app(RigService(RigSource.load(), f"sqlite:///{db}"), token=TOKEN,
                     manage_service=False)  # fmt: skip
    with TestClient(app) as c:
        yield c


def test_every_operation_is_documented_with_the_codes_its_route_declares(client):
    documented = _documented()
    problems = []
    for method, path, op in _operations(client.app):
        declared = set(op["responses"])
        row = documented.get((method, _norm(path)))
        if row is None:
            problems.append(f"{method.upper()} {path}: no row in docs/api.md")
        elif not row <= declared:
            problems.append(
                f"{method.upper()} {path}: docs/api.md names {sorted(row - declared)}, "
                f"the route declares {sorted(declared)}"
            )
    assert not problems, "\n".join(problems)


@contextlib.contextmanager
def database_down(service: RigService) -> Iterator[None]:
    """The module's service with its database unreachable (a PostgreSQL URL on a port
    bound and never listening): ``daq.store.faults.StorageUnavailable`` on every read."""
    with socket.socket() as closed:
        closed.bind(("127.0.0.1", 0))
        working = service.store.engine
        url = f"postgresql+psycopg://rig:secret@127.0.0.1:{closed.getsockname()[1]}/rig"
        service.store.engine = create_engine(url)
        try:
            yield
        finally:
            service.store.engine.dispose()
            service.store.engine = working


def test_every_reachable_documented_code_is_answered_and_nothing_undeclared(
    client, viewer, stopped, service
):
    wait_rig_free(client)
    undeclared: list[str] = []
    missed: list[str] = []
    # The database down first (every probe below needs it up): what a GET answers then must
    # be declared, and a 503 declared must be drawn by it or by a stopped service.
    with database_down(service):
        down = {
            path: client.get(_url(path), headers=AUTH).status_code
            for method, path, _ in _operations(client.app)
            if method == "get" and path != "/api/stream"
        }
    for method, path, op in _operations(client.app):
        if (method, path) in NOT_SENT:
            continue
        declared = set(op["responses"])
        url = _url(path)
        body: Any = b"t,position\n" if _csv_body(op) else [] if _has_body(op) else None
        # Every probe is sent whatever the route declares: what it answers must be declared;
        # what it is meant to draw, when declared, must be what it answers.
        attempts: list[tuple[str, str, Any, dict, dict]] = [("401", "no token", body, {}, {})]
        if method != "get":
            attempts.append(("403", "a viewer's token", body, viewer, {}))
        if "{" in path:
            attempts.append(("404", "an unknown id", None if _has_body(op) else body, AUTH, {}))
        if _has_body(op):
            attempts.append(("422", "a body it does not take", body, AUTH, {}))
            attempts.append(("413", "a body over the cap", OVER_CAP, AUTH, {}))
        elif (query := _bad_query(op)) is not None:
            attempts.append(("422", f"query {query}", None, AUTH, query))
        for code, why, sent, headers, query in attempts:
            if code == "404" and _has_body(op) and not _csv_body(op):
                sent = _valid_body(path)
            r = _send(client, method.upper(), url, headers, sent, params=query)
            got = str(r.status_code)
            if got not in declared and got not in ("200", "201", "202"):
                undeclared.append(f"{method.upper()} {path} ({why}): {got} {r.text[:120]}")
            elif got != code and code in declared:
                missed.append(f"{method.upper()} {path} ({why}): {got}, expected {code}")
        if method == "get" and path != "/api/stream":  # a stream of a stopped rig: no end
            r = stopped.get(url, headers=AUTH)
            if str(r.status_code) not in declared | {"200"}:
                undeclared.append(f"GET {path} (service stopped): {r.status_code} {r.text[:120]}")
            if str(down[path]) not in declared | {"200"}:
                undeclared.append(f"GET {path} (database down): {down[path]}")
            elif 503 not in (r.status_code, down[path]) and "503" in declared:
                missed.append(
                    f"GET {path} (service stopped, database down): {r.status_code} and "
                    f"{down[path]}, expected 503"
                )
    assert not undeclared, "answered but not declared:\n" + "\n".join(undeclared)
    assert not missed, "declared but not answered:\n" + "\n".join(missed)


def _valid_body(path: str) -> dict[str, Any] | None:
    """A body the route takes, so that its unknown id is what it answers."""
    if path.endswith("/move"):
        return {"position": 1}
    if path == "/api/queue/{job_id}":
        return {"force_n": 20.0, "drive": "weight"}
    if path.endswith("/metadata"):
        return {"notes": "x"}
    return None


def test_the_documented_state_conflicts(client, service):
    """409: an acknowledgement with no emergency stop latched; 423: a start while another
    user holds the rig (and 409 releasing a rig nobody holds, once released)."""
    wait_rig_free(client)
    r = client.post("/api/estop/ack", json={}, headers=AUTH)
    assert r.status_code == 409, r.text
    holder = {"Authorization": f"Bearer {UserRepository(service.store).add('hal', 'operator')}"}
    r = client.post("/api/rig/hold", json={"reason": "changing the load cell"}, headers=holder)
    assert r.status_code == 200, r.text
    try:
        r = client.post("/api/jobs/tow", json={"force_n": 20.0}, headers=AUTH)
        assert r.status_code == 423, r.text
        assert "hal" in r.json()["detail"]
    finally:
        assert client.post("/api/rig/release", json={}, headers=holder).status_code == 200
    r = client.post("/api/rig/release", json={}, headers=holder)
    assert r.status_code == 409, r.text
