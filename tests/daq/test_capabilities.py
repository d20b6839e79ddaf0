"""What a rig can do follows from the channels and sections its rig file lists
(``daq.rig_capabilities`` + ``KindSpec.needs``), and a request it cannot do is refused in one
line naming what is missing, before anything is opened."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from daq.config import load_rig, parse_rig
from daq.procedures.kind_spec import NotCapable
from daq.procedures.params import ParameterError
from daq.procedures.run_kinds import KINDS, RIG_KINDS, capabilities
from daq.procedures.sequence import parse_sequence
from daq.rig_capabilities import safety
from tests.support.cli import run_in_process

ROOT = Path(__file__).resolve().parents[2]
BENBAM = ROOT / "fixtures/rigs/benbam.toml"
ENCODER_TOW = ROOT / "fixtures/rigs/encoder-tow.toml"


def _benbam_without(*channels: str, sections: tuple[str, ...] = ()) -> dict:
    data = tomllib.loads(BENBAM.read_text(encoding="utf-8"))
    data["channels"] = [c for c in data["channels"] if c["name"] not in channels]
    for section in sections:
        data.pop(section)
    return data


def test_the_default_rig_can_do_everything_and_uses_every_safety_channel():
    rig = load_rig(BENBAM)
    caps = capabilities(rig)
    assert set(caps) == {str(k) for k in RIG_KINDS}  # a decay is imported, not run
    assert all(c["available"] for c in caps.values()), caps
    yes = {"available": True}
    assert caps["tow"]["drives"] == {"weight": yes, "thrusters": yes}
    assert all(c.available for c in safety(rig).values())


def test_the_minimal_rig_tows_with_a_weight_only_and_says_why_not_the_rest():
    rig = load_rig(ENCODER_TOW)
    assert rig.thrusters is None and rig.geometry.spin_drum_radius_m is None
    caps = capabilities(rig)
    assert caps["tow"]["available"] is True
    assert caps["tow"]["drives"]["weight"] == {"available": True}
    assert caps["tow"]["drives"]["thrusters"] == {
        "available": False,
        "reason": "tow with thrusters: needs a [thrusters] section",
    }
    assert caps["spin"] == {
        "available": False,
        "reason": "spin: needs channel yaw_angle, channel spin_release, limits.max_torque_nm",
        "drives": caps["spin"]["drives"],
    }
    assert caps["pendulum"]["reason"] == (
        "pendulum: needs channel pendulum_angle, channel pendulum_release, a [pendulum] section"
    )
    assert caps["thrust_calibration"]["reason"] == (
        "thrust_calibration: needs channel load_cell, a [thrusters] section"
    )
    used = safety(rig)
    assert not any(c.available for c in used.values())
    assert "stops when the encoder has travelled max_distance_m" in str(
        used["end_of_travel"].reason
    )


def test_each_missing_channel_takes_away_exactly_what_needs_it():
    rig = parse_rig(_benbam_without("tow_release"))
    caps = capabilities(rig)
    assert caps["tow"] == {
        "available": False,
        "reason": "tow: needs channel tow_release",
        "drives": caps["tow"]["drives"],
    }
    assert caps["spin"]["available"] and caps["pendulum"]["available"]
    rig = parse_rig(_benbam_without("load_cell", "estop", "heartbeat"))
    caps = capabilities(rig)
    assert caps["thrust_calibration"]["reason"] == "thrust_calibration: needs channel load_cell"
    assert caps["tow"]["available"] and caps["spin"]["available"]
    assert not safety(rig)["estop"].available and safety(rig)["end_of_travel"].available


def test_without_thrusters_only_the_thruster_drives_and_the_calibration_go():
    rig = parse_rig(_benbam_without(sections=("thrusters",)))
    caps = capabilities(rig)
    for kind in ("tow", "spin"):
        assert caps[kind]["available"] and caps[kind]["drives"]["weight"]["available"]
        assert not caps[kind]["drives"]["thrusters"]["available"]
    assert not caps["thrust_calibration"]["available"]
    assert caps["pendulum"]["available"]


def test_a_request_the_rig_cannot_do_is_one_line_naming_the_rig_and_what_is_missing():
    rig = load_rig(ENCODER_TOW)
    with pytest.raises(NotCapable) as err:
        KINDS["spin"].check({"torque_nm": 0.3}, rig)
    assert err.value.lines() == [
        "rig 'Encoder tow rig' cannot do this: spin: needs channel yaw_angle, "
        "channel spin_release, limits.max_torque_nm"
    ]
    assert err.value.to_json()[0]["field"] == "kind"
    with pytest.raises(NotCapable) as err:
        KINDS["tow"].check({"force_n": 5.0, "drive": "thrusters"}, rig)
    assert err.value.to_json()[0]["field"] == "drive"
    assert "tow with thrusters: needs a [thrusters] section" in str(err.value)
    assert isinstance(err.value, ParameterError)  # every face already reports those
    params = KINDS["tow"].check({"force_n": 9.8}, rig)
    assert params.max_distance_m == rig.geometry.end_of_travel_m  # the tow's distance limit


def test_a_sequence_step_the_rig_cannot_do_names_the_step():
    rig = load_rig(ENCODER_TOW)
    with pytest.raises(ParameterError) as err:
        parse_sequence(
            {"steps": [{"kind": "tow", "force_n": 4.9}, {"kind": "spin", "torque_nm": 0.3}]}, rig
        )
    assert err.value.problems[0][0] == "steps[1].kind"
    assert "spin: needs channel yaw_angle" in str(err.value)


def test_the_cli_refuses_a_kind_the_rig_cannot_do_in_one_line_before_opening_anything(
    tmp_path,
):
    db = tmp_path / "rig.db"
    for args, says in (
        (["spin", "--torque", "0.3"], "spin: needs channel yaw_angle"),
        (["tow", "--thrusters", "--force", "5"], "tow with thrusters: needs a [thrusters]"),
        (["calibrate-thrusters"], "thrust_calibration: needs channel load_cell"),
    ):
        argv = [*args, "--rig", str(ENCODER_TOW), "--db", f"sqlite:///{db}"]
        result = run_in_process(argv, cwd=ROOT, env=dict(os.environ))
        assert result.returncode == 2, result.stderr
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: rig 'Encoder tow rig' cannot do")
        assert says in lines[0]
    assert not db.exists()  # refused before the database (or the rig) was opened


def test_rig_capabilities_lists_each_test_or_why_not():
    def run(*args: str) -> str:
        argv = ["capabilities", "--rig", str(ENCODER_TOW), *args]
        done = run_in_process(argv, cwd=ROOT, env=dict(os.environ))
        assert done.returncode == 0, done.stderr
        return done.stdout

    data = json.loads(run("--json"))
    assert data["capabilities"] == capabilities(load_rig(ENCODER_TOW))
    assert data["safety"]["estop"]["available"] is False
    lines = run().splitlines()
    assert re.fullmatch(r"\s+rig tow\s+yes", lines[1])
    assert re.fullmatch(
        r"\s+rig tow --thrusters\s+no: tow with thrusters: needs a \[thrusters\] section", lines[2]
    )
    spin = r"\s+rig spin\s+no: spin: needs channel yaw_angle.*"
    assert any(re.fullmatch(spin, line) for line in lines)


def test_with_rig_file_set_once_help_lists_what_that_rig_cannot_do_and_commands_use_it(
    tmp_path,
):
    def rig(*args: str, rig_file: Path | None) -> subprocess.CompletedProcess[str]:
        env = {k: v for k, v in os.environ.items() if k != "RIG_FILE"}
        if rig_file is not None:
            env["RIG_FILE"] = str(rig_file)
        return run_in_process(list(args), cwd=ROOT, env=env)

    assert "Not on the rig" not in rig("--help", rig_file=None).stdout  # BENBAM does it all
    listed = rig("--help", rig_file=ENCODER_TOW).stdout.split("Not on the rig of $RIG_FILE:")[1]
    rows = dict(re.findall(r"^  (\S+(?: --\w+)?)\s+(.+)$", listed, re.M))
    assert rows["tow --thrusters"] == "tow with thrusters: needs a [thrusters] section"
    assert rows["spin"].startswith("spin: needs channel yaw_angle")
    assert "tow" not in rows and "spin --thrusters" not in rows  # spin is out whatever drives it
    broken = rig("--help", rig_file=tmp_path / "missing.toml")
    assert broken.returncode == 0 and "cannot read rig file" in " ".join(broken.stdout.split())
    # Every command takes $RIG_FILE as its --rig.
    db = tmp_path / "rig.db"
    refused = rig("spin", "--torque", "0.3", "--db", f"sqlite:///{db}", rig_file=ENCODER_TOW)
    assert refused.returncode == 2
    assert refused.stderr.startswith("error: rig 'Encoder tow rig' cannot do this: spin")


def test_a_simulated_rig_file_without_the_operator_registers_says_which_is_missing(tmp_path):
    text = ENCODER_TOW.read_text(encoding="utf-8")
    rig_file = tmp_path / "no-sim-channels.toml"
    rig_file.write_text(text[: text.index("# ---- simulation-only")], encoding="utf-8")
    done = subprocess.run(
        [sys.executable, "-m", "api.cli.main", "tow", "--force", "9.8", "--rig", str(rig_file),
         "--db", f"sqlite:///{tmp_path / 'rig.db'}"],
        capture_output=True, text=True, timeout=60, cwd=ROOT,
    )  # fmt: skip
    assert done.returncode == 1
    assert done.stderr.strip() == (
        "error: simulated operator: cannot return carriage: the rig file has no sim_only "
        "channel 'sim_reset' (docs/simulated-rig.md)"
    )
