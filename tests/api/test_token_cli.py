"""The bearer token: from RIG_API_TOKEN, else generated once into a 0600 file; ``rig token``."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
from click.testing import CliRunner

from api.cli.main import main
from api.http.auth import load_or_create_token, token_path
from tests.support.serve import stop_service, wait_healthy

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
    token is and 'rig token', never the token, and no library's warning at the first requests
    for the lists. Ctrl-C (SIGINT) stops it with exit 0 and a line saying the rig was left
    safe, not 'error: interrupted'."""
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
        secret = (tmp_path / "towrig" / "api-token").read_text().strip()
        # The lists a page asks for first (their filter and page models are built then).
        for path in ("api/runs?kind=tow", "api/results?limit=5", "api/jobs?state=queued"):
            answer = httpx.get(url + path, headers={"Authorization": f"Bearer {secret}"})
            assert answer.status_code == 200, (path, answer.text)
        # `rig token --link` links the port this service took (--port 0), unasked.
        with monkeypatch.context() as here:
            here.setenv("XDG_DATA_HOME", str(tmp_path))
            here.delenv("RIG_API_TOKEN", raising=False)
            link = CliRunner().invoke(main, ["token", "--link"])
        proc.send_signal(signal.SIGINT)
        code = proc.wait(30)
    finally:
        stop_service(proc)
    assert lines[1].startswith("rig file: the default (BENBAM); scenario: the default")
    assert lines[2].strip() == f"database: {db}"
    errors = proc.stderr.read()
    assert code == 0, errors
    assert "error:" not in errors and "rig service stopped: thrusters at zero" in errors

    assert "Warning" not in errors, errors  # a technician reads this terminal
    output = "".join(lines) + proc.stdout.read() + errors  # (it has exited)
    assert len(secret) >= 32 and secret not in output, output
    assert "#token=" not in output and "rig token --link" in output, output
    assert str(tmp_path / "towrig" / "api-token") in output  # where to find it
    assert link.output.strip() == f"{url}#token={secret}"  # only when asked for
    assert not (tmp_path / "towrig" / "api-address").exists()  # withdrawn when it stopped


def test_rig_token_link_takes_the_running_services_port_unless_told(tmp_path, monkeypatch):
    """The address a running service published beside its token file: its port (and host)
    unless --port/--host say otherwise; a file whose service is gone, or none, is 8000."""
    from api.http.address_file import address_path, publish_address, withdraw_address

    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))
    monkeypatch.setenv("RIG_API_TOKEN", "tok")

    def link(*args: str) -> str:
        result = CliRunner().invoke(main, ["token", "--link", *args])
        assert result.exit_code == 0, result.output
        return result.output.strip()

    publish_address("0.0.0.0", 8765)  # this process stands for the service
    assert link() == "http://127.0.0.1:8765/#token=tok"
    assert link("--port", "9001") == "http://127.0.0.1:9001/#token=tok"
    assert link("--host", "lab-pc") == "http://lab-pc:8765/#token=tok"
    withdraw_address()
    assert not address_path().exists()
    assert link() == "http://127.0.0.1:8000/#token=tok"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    address_path().write_text(f'{{"host": "127.0.0.1", "port": 8765, "pid": {dead.stdout}}}')
    assert link() == "http://127.0.0.1:8000/#token=tok"  # its service is gone


def test_rig_token_link_carries_the_token_for_the_browser(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))  # no service's address here
    monkeypatch.setenv("RIG_API_TOKEN", "a/b+c")
    result = CliRunner().invoke(main, ["token", "--link"])
    assert result.output.strip() == "http://127.0.0.1:8000/#token=a%2Fb%2Bc"
