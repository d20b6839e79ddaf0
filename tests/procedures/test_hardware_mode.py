"""A hardware rig file: the CLI drives external devices and asks a person for the operator acts.

`rig sim` in its own process stands in for the real rig (a Modbus TCP server and a thruster
pty); the rig file says mode = "hardware", so `rig tow` connects to those endpoints like to a
PLC and asks at the prompt for the weight and the carriage. The test plays the person: it
does what is asked through the simulator's operator registers, then presses Enter.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from pymodbus.client import ModbusTcpClient

from daq.config import load_rig
from daq.registers import encode
from daq.store import Store
from tests.procedures.conftest import hardware_rig_file
from tests.support.channel_readings import good
from tests.support.cli import answer_prompts, printed_json

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

ROOT = Path(__file__).resolve().parents[2]
RIG = [sys.executable, "-m", "api.cli.main"]


def test_tow_on_a_hardware_rig_file_asks_the_operator(tmp_path):
    sim = subprocess.Popen(
        [*RIG, "sim", "--modbus-port", "0"], cwd=ROOT, stdout=subprocess.PIPE, text=True
    )
    try:
        ready = json.loads(sim.stdout.readline())
        port, thruster_port = ready["modbus"]["port"], ready["thrusters"]["serial_port"]
        hw = hardware_rig_file(tmp_path, port, thruster_port)
        rig = load_rig(hw)
        db = f"sqlite:///{tmp_path / 'rig.db'}"
        tow = subprocess.Popen(
            [
                *RIG,
                "tow",
                "--force",
                "24.5",
                "--max-time",
                "2",
                "--baseline",
                "0.3",
                "--rig",
                str(hw),
                "--db",
                db,
                "--json",
            ],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        operator = ModbusTcpClient("127.0.0.1", port=port, timeout=1)
        operator.connect()

        def do_as_asked(prompt: str) -> None:
            if "Return the carriage" in prompt:
                operator.write_coil(rig.channel("sim_reset").address, True, device_id=1)
            elif m := re.search(r"Hang ([0-9.]+) kg on the tow line", prompt):
                ch = rig.channel("sim_tow_weight")
                operator.write_registers(ch.address, encode(ch, float(m.group(1))), device_id=1)

        asked, out = answer_prompts(tow, do_as_asked)
        tow.wait(30)
        operator.close()
        assert tow.returncode == 0, out
        assert asked[0].startswith("Return the carriage") and asked[1].startswith("Hang 2.500 kg")
        outcome = printed_json(out)
        assert outcome["status"] == "completed"
        with Store(db) as store:
            run = store.get_run(outcome["run_id"])
            assert 'mode = "hardware"' in run.rig_toml
            assert good(store.samples(run.id).channels["tow_position"])[-1] > 0.2
    finally:
        sim.terminate()
        sim.wait(10)
