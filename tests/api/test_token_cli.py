"""The bearer token: from RIG_API_TOKEN, else generated once into a 0600 file; ``rig token``."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from click.testing import CliRunner

from api.cli.main import main
from api.http.auth import load_or_create_token, token_path
from tests.serve import stop_service, wait_healthy

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]


def test_generated_token_is_private_and_stable(tmp_path, monkeypatch):
    monkeypatch.delenv("RIG_API_TOKEN", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    first = load_or_create_token()
    assert len(first) >= 32
    path = token_path()
    assert path == tmp_path / "towrig" / "api-token"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert load_or_create_token() == first


def test_environment_token_wins_and_rig_token_prints_it(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.setenv("RIG_API_TOKEN", "from-env")
    assert load_or_create_token() == "from-env"
    assert not token_path().exists()
    result = CliRunner().invoke(main, ["token"])
    assert result.exit_code == 0
    assert result.output.strip() == "from-env"


def test_rig_serve_is_a_command_with_safe_defaults():
    result = CliRunner().invoke(main, ["serve", "--help"])
    assert result.exit_code == 0
    assert "127.0.0.1" in result.output
    assert "--open-read" in result.output and "--cors-origin" in result.output


def test_rig_serve_banner_names_what_it_serves_never_the_token_and_ctrl_c_stops_it(
    tmp_path, monkeypatch
):
    """One ``rig serve`` process, as a person runs it. Its output lands in service logs: the
    address, the rig file, the scenario and the database (a password masked), where the
    token is and 'rig token', never the token. Ctrl-C (SIGINT) stops it with exit 0 and a
    line saying the rig was left safe, not 'error: interrupted'."""
    env = os.environ | {"XDG_DATA_HOME": str(tmp_path), "PYTHONUNBUFFERED": "1"}
    env.pop("RIG_API_TOKEN", None)
    env["RIG_SPILL_DIR"] = str(tmp_path / "spill")
    db = f"sqlite:///{tmp_path}/lab.db"
    proc = subprocess.Popen(
        [sys.executable, "-m", "api.cli.serve", "--port", "0", "--db", db],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        lines = [proc.stdout.readline() for _ in range(3)]
        assert lines[0].startswith("rig service: http://127.0.0.1:"), lines
        url = lines[0].split()[2]
        wait_healthy(proc, url, proc.stderr.read, timeout_s=30)
        proc.send_signal(signal.SIGINT)
        code = proc.wait(30)
    finally:
        stop_service(proc)
    assert lines[1].startswith("rig file: the default (BENBAM); scenario: the default")
    assert lines[2].strip() == f"database: {db}"
    errors = proc.stderr.read()
    assert code == 0, errors
    assert "error:" not in errors and "rig service stopped: thrusters at zero" in errors

    output = "".join(lines) + proc.stdout.read() + errors  # (it has exited)
    secret = (tmp_path / "towrig" / "api-token").read_text().strip()
    assert len(secret) >= 32 and secret not in output, output
    assert "#token=" not in output and "rig token --link" in output, output
    assert str(tmp_path / "towrig" / "api-token") in output  # where to find it
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))  # the service's token file
    monkeypatch.delenv("RIG_API_TOKEN", raising=False)
    link = CliRunner().invoke(main, ["token", "--link", "--port", url.rsplit(":", 1)[1][:-1]])
    assert link.output.strip() == f"{url}#token={secret}"  # only when asked for


def test_rig_token_link_carries_the_token_for_the_browser(tmp_path, monkeypatch):
    monkeypatch.setenv("RIG_API_TOKEN", "a/b+c")
    result = CliRunner().invoke(main, ["token", "--link"])
    assert result.output.strip() == "http://127.0.0.1:8000/#token=a%2Fb%2Bc"
