"""Rig-file validation: registers must fit the 16-bit address space, and an unreadable
or binary file is one line naming the file (library and CLI); a run's stored rig file is
parsed once per distinct text, its errors naming the run."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from daq.config import RigConfigError, load_rig, parse_rig_text
from tests.support.cli import run_in_process

ROOT = Path(__file__).resolve().parents[2]
BENBAM = ROOT / "fixtures/rigs/benbam.toml"


def _rig_with_tow_position_at(tmp_path: Path, address: int) -> Path:
    text = BENBAM.read_text()
    marker = 'name = "tow_position"\nkind = "input"\naddress = 0\n'
    assert marker in text
    path = tmp_path / "rig.toml"
    path.write_text(text.replace(marker, marker.replace("address = 0", f"address = {address}")))
    return path


def test_a_32_bit_channel_at_the_last_address_is_refused_naming_channel_and_range(tmp_path):
    with pytest.raises(RigConfigError) as err:
        load_rig(_rig_with_tow_position_at(tmp_path, 65535))
    message = str(err.value)
    assert "channel 'tow_position'" in message
    assert "address 65535" in message and "int32" in message
    assert "allowed address 0..65534" in message
    assert len(message.splitlines()) == 1


def test_a_32_bit_channel_that_just_fits_is_accepted(tmp_path):
    rig = load_rig(_rig_with_tow_position_at(tmp_path, 65534))
    assert rig.channel("tow_position").address == 65534


def test_a_binary_rig_file_is_one_line_naming_the_file(tmp_path):
    path = tmp_path / "rig.toml"
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\xff\xfe")
    with pytest.raises(RigConfigError) as err:
        load_rig(path)
    assert str(err.value).startswith(f"{path}: not a rig file: not UTF-8 text")
    assert len(str(err.value).splitlines()) == 1


def test_the_cli_reports_a_binary_or_unreadable_rig_file_without_a_traceback(tmp_path):
    binary = tmp_path / "rig.bin"
    binary.write_bytes(bytes(range(256)))
    folder = tmp_path / "a-folder.toml"
    folder.mkdir()
    for path, says in ((binary, "not UTF-8 text"), (folder, "cannot read rig file")):
        argv = [
            "tow",
            "--force",
            "5",
            "--rig",
            str(path),
            "--db",
            f"sqlite:///{tmp_path / 'rig.db'}",
        ]
        result = run_in_process(argv, cwd=ROOT, env=dict(os.environ))  # refused before opening
        assert result.returncode == 2, result.stderr
        assert str(path) in result.stderr and says in result.stderr
        assert "Traceback" not in result.stderr
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_a_stored_rig_text_is_parsed_once_and_its_errors_name_the_run(tmp_path):
    """An estimate's steps each ask for their runs' rig (issue 33: 11 parses of one text)."""
    text = BENBAM.read_text()
    first = parse_rig_text(text, "run a rig file")
    assert parse_rig_text(text, "run b rig file") is first  # the same text: the same parse
    assert first == load_rig(BENBAM)
    bad = text.replace("address = 0\n", "address = 65535\n", 1)
    for source in ("run c rig file", "run d rig file"):  # a bad text is not cached
        with pytest.raises(RigConfigError, match=f"^{source}: "):
            parse_rig_text(bad, source)
    with pytest.raises(RigConfigError, match=r"^run e rig file: not valid TOML: "):
        parse_rig_text("[rig\n", "run e rig file")
