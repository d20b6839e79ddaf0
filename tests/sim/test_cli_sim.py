"""``rig sim`` as a subprocess: its JSON line, clean shutdown, errors, and mbpoll."""

from __future__ import annotations

import json
import select
import signal
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from pymodbus.client import ModbusTcpClient

from daq.config import load_rig
from daq.registers import decode
from tests.conftest import require_tool
from tests.support.waiting import ANSWER_S, wait_until

REPO = Path(__file__).resolve().parents[2]
RIG_SIM = [sys.executable, "-c", "from api.cli.main import main; main()", "sim"]


class RigSim:
    """A running ``rig sim`` and the JSON line it printed."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [*RIG_SIM, *args], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        ready, _, _ = select.select([self.proc.stdout], [], [], 30.0)
        line = self.proc.stdout.readline() if ready else ""
        if not line:
            self.proc.kill()
            raise AssertionError(f"rig sim printed no JSON line: {self.proc.stderr.read()[-800:]}")
        self.ready = json.loads(line)

    def stop(self, sig: int = signal.SIGTERM) -> tuple[int, str, str]:
        self.proc.send_signal(sig)
        out, err = self.proc.communicate(timeout=10)
        return self.proc.returncode, out, err


@pytest.fixture
def rig_sim():
    running = RigSim("--modbus-port", "0")
    yield running
    if running.proc.poll() is None:
        running.proc.kill()
        running.proc.wait()


def test_json_line_then_clean_exit_on_sigterm(rig_sim):
    ready = rig_sim.ready
    assert set(ready) >= {"modbus", "thrusters", "registers", "pid"}
    assert ready["pid"] == rig_sim.proc.pid
    assert ready["modbus"]["transport"] == "tcp" and ready["modbus"]["port"] > 0
    assert ready["modbus"]["unit_id"] == 1
    assert Path(ready["thrusters"]["serial_port"]).exists()
    assert ready["thrusters"]["count"] == 2
    pos = ready["registers"]["tow_position"]
    assert pos == {**pos, "kind": "input", "address": 0, "type": "int32", "word_order": "big"}
    assert ready["registers"]["sim_tow_weight"]["sim_only"] is True
    code, out, err = rig_sim.stop(signal.SIGTERM)
    assert code == 0, err
    assert out == "", "exactly one JSON line on stdout"
    assert "Traceback" not in err


def test_sigint_exits_cleanly(rig_sim):
    code, _, err = rig_sim.stop(signal.SIGINT)
    assert code == 0 and "Traceback" not in err


def test_bad_scenario_exits_2_naming_the_field(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[effects]\nbias_force_n = 500\n")
    proc = subprocess.run(
        [*RIG_SIM, "--modbus-port", "0", "--scenario", str(bad)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert "effects.bias_force_n" in proc.stderr and "(got 500)" in proc.stderr
    assert "Traceback" not in proc.stderr


def test_port_in_use_exits_2():
    with socket.socket() as busy:
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        port = busy.getsockname()[1]
        proc = subprocess.run(
            [*RIG_SIM, "--modbus-port", str(port)],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert proc.returncode == 2 and proc.stdout == ""
    assert "--modbus-port" in proc.stderr and str(port) in proc.stderr


def mbpoll(exe: str, port: int, *args: str) -> str:
    cmd = [exe, "-m", "tcp", "-a", "1", "-p", str(port), "-0", "-1", "-o", "1", *args]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=10)
    assert proc.returncode == 0, f"{cmd}: {proc.stdout}{proc.stderr}"
    return proc.stdout


def mbpoll_values(output: str) -> dict[int, int]:
    """``[ref]: value`` lines of an mbpoll read."""
    values = {}
    for line in output.splitlines():
        if line.startswith("[") and "]:" in line:
            ref, value = line[1:].split("]:")
            values[int(ref)] = int(value.strip())
    return values


def test_mbpoll_reads_registers_and_releases_the_tow(rig_sim):
    exe = require_tool(
        "mbpoll", "independent Modbus master for the simulated PLC (apt install mbpoll)"
    )
    port = rig_sim.ready["modbus"]["port"]
    regs = rig_sim.ready["registers"]
    rig = load_rig()
    words = mbpoll_values(mbpoll(exe, port, "-t", "3", "-r", "0", "-c", "10", "127.0.0.1"))
    assert sorted(words) == list(range(10))
    supply = rig.channel("supply_voltage")
    assert decode(supply, [words[supply.address]]) == pytest.approx(16.0, abs=0.2)
    load = rig.channel("load_cell")
    assert decode(load, [words[load.address], words[load.address + 1]]) == pytest.approx(
        0.3, abs=0.3
    )
    # hang 2.5 kg (uint32, high word first) and release the brake, as an operator tool would
    weight = regs["sim_tow_weight"]
    mbpoll(exe, port, "-t", "4:int", "-B", "-r", str(weight["address"]), "127.0.0.1", "2500")
    mbpoll(exe, port, "-t", "0", "-r", str(regs["tow_release"]["address"]), "127.0.0.1", "1")
    client = ModbusTcpClient("127.0.0.1", port=port, timeout=ANSWER_S, retries=0)
    assert client.connect()
    try:
        coil = client.read_coils(regs["tow_release"]["address"], count=1, device_id=1)
        assert coil.bits[0] is True
        pos = rig.channel("tow_position")

        def read() -> float:
            return decode(pos, client.read_input_registers(0, count=2, device_id=1).registers)

        first = read()
        wait_until(lambda: read() > first, "the released vehicle moving", timeout_s=10)
        later = read()
    finally:
        client.close()
    # mbpoll reads the 32-bit position too, and an unmapped register is refused
    counts = mbpoll_values(mbpoll(exe, port, "-t", "3:int", "-B", "-r", "0", "127.0.0.1"))
    assert counts[0] * pos.scale >= later
    refused = subprocess.run(
        [
            exe,
            "-m",
            "tcp",
            "-a",
            "1",
            "-p",
            str(port),
            "-0",
            "-1",
            "-t",
            "3",
            "-r",
            "50",
            "127.0.0.1",
        ],
        capture_output=True,
        text=True,
        timeout=10,
    )
    assert "Illegal data address" in refused.stdout + refused.stderr


def test_rtu_flag_serves_modbus_rtu_on_a_pty():
    from pymodbus.client import ModbusSerialClient

    running = RigSim("--rtu")
    try:
        mb = running.ready["modbus"]
        assert mb["transport"] == "rtu" and Path(mb["serial_port"]).exists()
        client = ModbusSerialClient(
            mb["serial_port"], baudrate=mb["baudrate"], timeout=ANSWER_S, retries=0
        )
        assert client.connect()
        try:
            rr = client.read_input_registers(6, count=1, device_id=mb["unit_id"])
            assert not rr.isError() and 1500 < rr.registers[0] < 1700  # 16 V in 10 mV counts
        finally:
            client.close()
        code, out, _ = running.stop()
        assert code == 0 and out == ""
    finally:
        if running.proc.poll() is None:
            running.proc.kill()
            running.proc.wait()
