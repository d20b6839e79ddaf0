"""The bearer token: from RIG_API_TOKEN, else generated once into a 0600 file; ``rig token``."""

from __future__ import annotations

import stat

from click.testing import CliRunner

from api.cli.main import main
from api.http.auth import load_or_create_token, token_path


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
