"""A rig of two channels on a PLC that is neither the simulator nor built on pymodbus.

pyModbusTCP's ``ModbusServer`` (its own Modbus TCP implementation) stands in for a lab's
PLC (``tests.support.cart_plc``, in a process of its own as a PLC has a CPU of its own): the
encoder is a uint32 in two holding registers, the brake a coil, nothing else: no
end-of-travel switch, no e-stop, no heartbeat, no thrusters. The PLC's program rolls the
cart while the brake is released, like a weight-driven carriage; the test plays the
operator (Enter at each prompt), and `rig tow` runs end to end against it as a user would.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from daq.store import Store
from tests.support.cart_plc import (
    CART_SPEED_M_S,
    ENCODER_ADDRESS,
    METRES_PER_COUNT,
    RELEASE_COIL,
    CartPlc,
)
from tests.support.cli import answer_prompts, printed_json

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]
RIG = [sys.executable, "-m", "api.cli.main"]

RIG_FILE = """
[rig]
name = "Two-channel lab rig"
mode = "hardware"
g = 9.8

[geometry]
rail_length_m = 3.0
end_of_travel_m = 2.5
pulley_radius_m = 0.05

[vehicle]
name = "box"
dry_mass_kg = 12.0

[modbus]
host = "127.0.0.1"
port = {port}
unit_id = 1

[limits]
max_force_n = 50.0
max_speed_m_s = 1.0

[[channels]]
name = "tow_position"
kind = "holding"
address = {encoder}
type = "uint32"
word_order = "big"
scale = {scale}
unit = "m"

[[channels]]
name = "tow_release"
kind = "coil"
address = {release}
type = "bool"
"""


def rig_file_text(port: int) -> str:
    return RIG_FILE.format(
        port=port, encoder=ENCODER_ADDRESS, release=RELEASE_COIL, scale=METRES_PER_COUNT
    )


@pytest.fixture
def cart_plc():
    plc = CartPlc()
    plc.start()
    try:
        yield plc
    finally:
        plc.stop()


def test_rig_tow_runs_on_a_two_channel_rig_against_a_pymodbustcp_plc(cart_plc, tmp_path):
    rig_file = tmp_path / "lab.toml"
    rig_file.write_text(rig_file_text(cart_plc.port), encoding="utf-8")
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    tow = subprocess.Popen(
        [*RIG, "tow", "--force", "4.9", "--max-distance", "0.4", "--max-time", "10",
         "--baseline", "0.3", "--rig", str(rig_file), "--db", db, "--json"],
        cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip

    def operator(prompt: str) -> None:  # confirms; the weight is hung by hand
        if "Return the carriage" in prompt:
            cart_plc.reset()

    asked, out = answer_prompts(tow, operator)
    tow.wait(60)
    err = tow.stderr.read() if tow.stderr else ""
    assert tow.returncode == 0, out + err
    assert "Traceback" not in err
    assert asked[0].startswith("Return the carriage") and asked[1].startswith("Hang 0.500 kg")
    outcome = printed_json(out)
    assert outcome["status"] == "completed"
    assert cart_plc.state()["braked_after_release"], "the brake was never engaged after the tow"
    with Store(db) as store:
        run = store.get_run(outcome["run_id"])
        assert list(run.channel_names) == ["tow_position", "tow_release"]
        events = [e.message for e in store.events(run.id)]
        assert any("max distance 0.4 m" in m for m in events), events  # no switch: by distance
        table = store.samples(run.id)
        assert len(table) == outcome["samples"] > 10
        position = table.channels["tow_position"]
        # a poll the PLC answered late (a loaded host) is a NaN sample, flagged,
        # and the run names the loss; a rehearsal beside a busy loop had one as the last
        unread = ~np.isfinite(position)
        assert all(table.quality[unread] != 0)
        if unread.any():
            assert any("lost" in m and "PLC read failed" in m for m in events), events
        last_read = position[~unread][-1]
        assert 0.4 <= last_read < 0.4 + CART_SPEED_M_S * 0.5  # braked soon after 0.4 m
        # released after the baseline: the first samples are at rest, the release comes
        # later (how many samples a 0.3 s baseline holds depends on the host's timing: a
        # rehearsal under load recorded two, not three)
        # a poll that failed under load stores NaN in every channel of its sample, flagged,
        # and the run names the loss (the rehearsal of 1b81e7e's parent saw one right before
        # the release, CI at c75c4f1 and the rehearsal of 9a467e6 the first sample)
        release = table.channels["tow_release"]
        released = release[np.isfinite(release)]
        assert released[0] == 0.0 and 1.0 in released
        first = int(np.flatnonzero(release == 1.0)[0])
        # every position read before the release is at rest (the baseline)
        before = position[:first]
        read = np.isfinite(before) & np.isfinite(release[:first])
        assert read.any() and np.allclose(before[read], 0.0, atol=1e-4), before
        assert all(table.quality[:first][~read] != 0)
        if not read.all():
            assert any("lost" in m and "PLC read failed" in m for m in events), events


@pytest.mark.parametrize("port", ["{tmp}/no-such-tty", "nonsense://thrusters"])
def test_a_thruster_port_that_cannot_be_opened_is_one_line_naming_device_and_setting(
    cart_plc, tmp_path, port
):
    port = port.format(tmp=tmp_path)
    rig_file = tmp_path / "lab.toml"
    text = rig_file_text(cart_plc.port) + f'\n[thrusters]\nport = "{port}"\ncount = 2\n'
    rig_file.write_text(text, encoding="utf-8")
    result = subprocess.run(
        [*RIG, "tow", "--force", "4.9", "--rig", str(rig_file),
         "--db", f"sqlite:///{tmp_path / 'rig.db'}"],
        cwd=ROOT, capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL,
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr  # no traceback, no warning about a port never opened
    assert lines[0].startswith("error: thruster controller: thrusters.port: cannot open ")
    assert repr(port) in lines[0]
