"""Limits at the edge: body caps before parsing and auth (over a real socket), caps on
sequence steps and calibration commands, the Host check of an open-read service, and the
token file's mode."""

from __future__ import annotations

import json
import os
import socket
import stat
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from click.testing import CliRunner
from fastapi.testclient import TestClient

from api.cli.main import main
from api.http.app import create_app
from api.http.auth import token_file_warning, token_path
from api.http.limits import JSON_BODY_LIMIT
from daq.procedures.params import MAX_SEQUENCE_STEPS
from daq.procedures.requests import MAX_CALIBRATION_COMMANDS
from tests.api.conftest import AUTH, TOKEN, LiveServer
from tests.api.streamed_post import feed_post, zeros

ROOT = Path(__file__).resolve().parents[2]
HUGE = 300 * 1024 * 1024
UPLOAD_LIMIT = 1024 * 1024


class Counting:
    """ASGI wrapper outside the whole app: counts the body bytes the app pulled, and the
    largest message (the server coalesces body data while the app is busy)."""

    def __init__(self, app) -> None:
        self.app = app
        self.pulled = 0
        self.largest = 0

    async def __call__(self, scope, receive, send):
        async def counted():
            message = await receive()
            self.pulled += len(message.get("body", b""))
            self.largest = max(self.largest, len(message.get("body", b"")))
            return message

        await self.app(scope, counted, send)


@pytest.fixture(scope="module")
def edge(service, client):
    app = create_app(
        service,
        token=TOKEN,
        manage_service=False,
        runner=client.app.state.runner,
        max_upload_bytes=UPLOAD_LIMIT,
    )
    counting = Counting(app)
    with LiveServer(counting) as live:
        yield counting, live.sock.getsockname()[1]


def _post(port: int, path: str, headers: dict[str, str], body: Iterator[bytes], *, chunked: bool):
    """Send a POST over a raw socket, feeding the body only while the server has not
    answered; returns (status, JSON body, body bytes handed to the socket)."""
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        sent = feed_post(s, path, headers, body, chunked=chunked)
        s.settimeout(10)
        data = b""
        while b"\r\n\r\n" not in data:
            data += s.recv(65536)
        header, _, rest = data.partition(b"\r\n\r\n")
        length = int(next(
            line.split(b":")[1] for line in header.split(b"\r\n")
            if line.lower().startswith(b"content-length")
        ))  # fmt: skip
        while len(rest) < length:
            rest += s.recv(65536)
    status = int(header.split(b" ")[1])
    return status, json.loads(rest[:length]), sent


@pytest.mark.parametrize("path", ["/api/jobs/tow", "/api/runs/import?kind=tow&force_n=5"])
def test_a_declared_300_mb_unauthenticated_body_is_413_before_a_byte_is_read(edge, path):
    counting, port = edge
    before = counting.pulled
    status, body, sent = _post(
        port,
        path,
        {"Content-Type": "application/json", "Content-Length": str(HUGE)},
        zeros(HUGE),
        chunked=False,
    )
    assert status == 413
    assert f"{HUGE} bytes" in body["detail"] and "limit" in body["detail"]
    assert counting.pulled == before  # the app never read the body
    print(f"sent {sent} bytes, app pulled {counting.pulled - before}")
    assert sent < HUGE // 10  # the client stopped feeding once answered


def test_a_streamed_300_mb_unauthenticated_json_body_is_refused_unread(edge):
    counting, port = edge
    before = counting.pulled
    status, body, sent = _post(
        port, "/api/jobs/tow", {"Content-Type": "application/json"}, zeros(HUGE), chunked=True
    )
    assert status == 401  # no token: refused before the body is read (issue 19)
    assert "bearer token" in body["detail"]
    assert counting.pulled - before <= counting.largest  # not a message of it parsed
    assert sent < HUGE // 10


def test_a_streamed_300_mb_json_body_with_the_token_stops_at_the_cap(edge):
    counting, port = edge
    before = counting.pulled
    status, body, sent = _post(
        port,
        "/api/jobs/tow",
        AUTH | {"Content-Type": "application/json"},
        zeros(HUGE),
        chunked=True,
    )
    assert status == 413
    assert f"{JSON_BODY_LIMIT}-byte limit" in body["detail"]
    # read no further than the message that crossed the cap
    assert counting.pulled - before <= JSON_BODY_LIMIT + counting.largest
    assert sent < HUGE // 10


def test_a_streamed_csv_over_the_upload_cap_is_413(edge):
    _, port = edge
    status, body, sent = _post(
        port,
        "/api/runs/import?kind=tow&force_n=5",
        AUTH | {"Content-Type": "text/csv"},
        zeros(HUGE),
        chunked=True,
    )
    assert status == 413
    assert f"{UPLOAD_LIMIT}-byte limit" in body["detail"]
    assert sent < HUGE // 10


def test_a_small_unauthenticated_body_still_gets_401(edge):
    _, port = edge
    payload = b'{"force_n": 5}'
    headers = {"Content-Type": "application/json", "Content-Length": str(len(payload))}
    status, body, _ = _post(port, "/api/jobs/tow", headers, iter([payload]), chunked=False)
    assert status == 401
    assert "bearer token" in body["detail"]


def test_too_many_sequence_steps_or_calibration_commands_is_422_naming_field_and_limit(client):
    steps = [{"kind": "tow", "force_n": 5.0}] * (MAX_SEQUENCE_STEPS + 1)
    r = client.post("/api/jobs/sequence", json={"steps": steps}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "steps"
    assert f"at most {MAX_SEQUENCE_STEPS} items" in r.json()["detail"]
    commands = [0.01 * i for i in range(MAX_CALIBRATION_COMMANDS + 1)]
    r = client.post("/api/jobs/calibration", json={"commands": commands}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "commands"
    assert f"at most {MAX_CALIBRATION_COMMANDS} items" in r.json()["detail"]
    # a calibration inside a sequence is held to the same cap
    step = {"kind": "thrust_calibration", "commands": commands}
    r = client.post("/api/jobs/sequence", json={"steps": [step]}, headers=AUTH)
    assert r.status_code == 422
    assert r.json()["errors"][0]["field"] == "steps[0].commands"
    assert f"at most {MAX_CALIBRATION_COMMANDS} commands" in r.json()["detail"]


def test_the_caps_are_in_the_openapi_schema(client):
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    assert schemas["SequenceRequest"]["properties"]["steps"]["maxItems"] == MAX_SEQUENCE_STEPS
    commands = schemas["CalibrationRequest"]["properties"]["commands"]["anyOf"][0]
    assert commands["maxItems"] == MAX_CALIBRATION_COMMANDS


def test_the_cli_has_the_same_caps(tmp_path):
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    commands = ",".join(str(0.01 * i) for i in range(MAX_CALIBRATION_COMMANDS + 1))
    sequence = tmp_path / "long.toml"
    sequence.write_text('[[steps]]\nkind = "tow"\nforce_n = 5.0\n' * (MAX_SEQUENCE_STEPS + 1))
    for args, says in (
        (["calibrate-thrusters", "--commands", commands], f"at most {MAX_CALIBRATION_COMMANDS}"),
        (["sequence", str(sequence)], f"at most {MAX_SEQUENCE_STEPS} steps"),
    ):
        result = subprocess.run(
            [sys.executable, "-m", "api.cli.main", *args, "--db", db],
            capture_output=True, text=True, timeout=60, cwd=ROOT,
        )  # fmt: skip
        assert result.returncode == 2, result.stderr
        assert says in result.stderr and "Traceback" not in result.stderr


def test_an_open_read_service_answers_only_local_or_named_hosts(service, client):
    app = create_app(
        service,
        token=TOKEN,
        open_read=True,
        allowed_hosts=["rig.lab.example"],
        manage_service=False,
        runner=client.app.state.runner,
    )
    with TestClient(app, base_url="http://localhost:8000") as c:
        assert c.get("/api/runs").status_code == 200
        for host in ("127.0.0.1:8000", "localhost", "[::1]:8000", "rig.lab.example"):
            assert c.get("/api/runs", headers={"Host": host}).status_code == 200, host
        for host in ("attacker.example", "attacker.example:8000", "127.0.0.1.nip.io"):
            r = c.get("/api/runs", headers={"Host": host})
            assert r.status_code == 400, host
            assert c.get("/api/stream?max_events=1", headers={"Host": host}).status_code == 400
    serve_help = CliRunner().invoke(main, ["serve", "--help"]).output
    assert "--allow-host" in serve_help


def test_a_token_file_readable_by_others_is_warned_about_with_the_fix(tmp_path, monkeypatch):
    monkeypatch.delenv("RIG_API_TOKEN", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    path = token_path()
    path.parent.mkdir(parents=True)
    path.write_text("an-old-token\n")
    os.chmod(path, 0o644)
    warning = token_file_warning()
    assert warning is not None
    assert str(path) in warning and "0644" in warning and f"chmod 600 {path}" in warning
    result = CliRunner().invoke(main, ["token"])
    assert result.exit_code == 0
    assert result.stdout.strip() == "an-old-token"
    assert f"chmod 600 {path}" in result.stderr
    os.chmod(path, 0o600)
    assert token_file_warning() is None
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert CliRunner().invoke(main, ["token"]).stderr == ""
