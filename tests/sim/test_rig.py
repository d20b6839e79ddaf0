"""The whole simulated rig in its own thread: Modbus plus the thruster serial line."""

from __future__ import annotations

import gc
import time

import pytest
import serial
from pymodbus.client import ModbusTcpClient

from daq.collector import hold_full_collections
from daq.config import load_rig
from daq.registers import decode
from daq.sim.simulated_rig import SimulatedRigThread
from tests.support.waiting import ANSWER_S, wait_until
from thrusters import protocol

RIG = load_rig()


def send(port: serial.Serial, frame: bytes) -> protocol.Reply:
    port.write(frame)
    line = port.readline()
    assert line.endswith(b"\r\n"), line
    return protocol.parse_reply(line)


def read_load_cell(client: ModbusTcpClient) -> float:
    ch = RIG.channel("load_cell")
    rr = client.read_input_registers(ch.address, count=ch.width, device_id=RIG.modbus.unit_id)
    assert not rr.isError()
    return decode(ch, rr.registers)


def test_thread_runner_serves_modbus_and_thrusters_on_the_stand():
    with SimulatedRigThread(RIG) as sim:
        ep = sim.endpoints
        conn = sim.connection_rig()
        assert conn.modbus.port == ep.port and conn.thrusters.port == ep.thruster_serial_port
        assert ep.modbus_transport == "tcp" and ep.thruster_count == RIG.thrusters.count
        client = ModbusTcpClient("127.0.0.1", port=ep.port, timeout=ANSWER_S, retries=0)
        assert client.connect()
        line = serial.serial_for_url(ep.thruster_serial_port, baudrate=115200, timeout=ANSWER_S)
        try:
            stand = RIG.channel("sim_thrust_stand")
            assert not client.write_coil(stand.address, True, device_id=1).isError()
            idle = read_load_cell(client)
            # this test is the host: like the driver (daq.collector), no full collection
            # while armed, whose pause in a loaded worker would miss the 0.4 s watchdog
            gc.collect()
            hold_full_collections(True)
            try:
                assert send(line, protocol.arm_frame(1)).kind == "ACK"
                for seq in range(2, 7):  # 0.6 s of thrust = 4 lag time constants
                    assert send(line, protocol.thr_frame(seq, [500, 500])).kind == "ACK"
                    time.sleep(0.12)  # paced like a host, each frame within the watchdog
            finally:
                hold_full_collections(False)
            thrust = read_load_cell(client) - idle
            expected = 2 * sim.plant.static_thrust_n(0.5, sim.plant.loaded_voltage_v())
            assert thrust == pytest.approx(expected, rel=0.08)
            sta = send(line, protocol.qry_frame(7))
            assert sta.kind == "STA"
            # no frames: the watchdog (0.4 s) trips and zeroes the outputs
            wait_until(lambda: sim.call(lambda s: s.thrusters.state) == "WDT", "watchdog trip")
            assert sim.plant.commands == [0.0, 0.0]
        finally:
            line.close()
            client.close()


def test_call_runs_fault_injection_on_the_simulators_loop():
    with SimulatedRigThread(RIG) as sim:
        client = ModbusTcpClient("127.0.0.1", port=sim.endpoints.port, timeout=0.2, retries=0)
        assert client.connect()
        try:
            sim.call(lambda s: setattr(s.plc.faults, "drop", True))
            with pytest.raises(Exception):  # noqa: B017 - any client error is right here
                client.read_input_registers(0, count=2, device_id=1)
            sim.call(lambda s: s.plc.faults.clear())
            sim.call(sim.plc.stop_server)
            sim.call(sim.plc.start_server)
            client.close()
            client = ModbusTcpClient(
                "127.0.0.1", port=sim.endpoints.port, timeout=ANSWER_S, retries=0
            )
            assert client.connect()
            assert not client.read_input_registers(0, count=2, device_id=1).isError()
        finally:
            client.close()


def test_rtu_rig_points_the_connection_at_a_pty():
    with SimulatedRigThread(RIG, rtu=True) as sim:
        conn = sim.connection_rig()
        assert conn.modbus.transport == "rtu" and conn.modbus.serial_port.startswith("/dev/")
    with pytest.raises(ValueError, match="rtu"):
        SimulatedRigThread(RIG, rtu="udp")


def test_socket_urls_for_modbus_rtu_and_thrusters():
    from pymodbus.client import ModbusSerialClient

    with SimulatedRigThread(RIG, rtu="socket", thruster_transport="tcp") as sim:
        ep = sim.endpoints
        assert ep.serial_port.startswith("socket://") and ep.port is None
        assert ep.thruster_serial_port.startswith("socket://")
        client = ModbusSerialClient(ep.serial_port, timeout=ANSWER_S, retries=0)
        assert client.connect()
        line = serial.serial_for_url(ep.thruster_serial_port, timeout=ANSWER_S)
        try:
            assert not client.read_input_registers(0, count=10, device_id=1).isError()
            assert send(line, protocol.arm_frame(1)).kind == "ACK"
        finally:
            line.close()
            client.close()
