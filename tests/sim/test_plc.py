"""The simulated PLC over real sockets and ptys, read by pymodbus clients."""

from __future__ import annotations

import asyncio
import itertools
from collections.abc import Iterator
from contextlib import contextmanager

import pytest
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.exceptions import ModbusException

from daq.config import load_rig
from daq.registers import decode, encode
from daq.sim.plant import Plant
from daq.sim.plc_server import SimulatedPLC
from tests.support.waiting import ANSWER_S, until

RIG = load_rig()
UNIT = RIG.modbus.unit_id


@pytest.fixture
async def plc():
    simulated = SimulatedPLC(RIG, Plant(RIG))
    yield simulated
    await simulated.stop()


async def tcp_client(port: int, timeout: float = ANSWER_S) -> AsyncModbusTcpClient:
    client = AsyncModbusTcpClient("127.0.0.1", port=port, timeout=timeout, retries=0)
    assert await client.connect()
    return client


async def rtu_client(port: str, timeout: float = ANSWER_S) -> AsyncModbusSerialClient:
    """A connected RTU client on ``port`` (a pty path or a ``socket://`` URL)."""
    client = AsyncModbusSerialClient(port, baudrate=RIG.modbus.baudrate, timeout=timeout, retries=0)
    assert await client.connect()
    return client


@contextmanager
def patient(client: AsyncModbusTcpClient | AsyncModbusSerialClient) -> Iterator[None]:
    """Within: ``client`` waits `ANSWER_S` for an answer (a read expected to succeed), then
    its short fault timeout again."""
    short = client.comm_params.timeout_connect
    client.comm_params.timeout_connect = ANSWER_S
    try:
        yield
    finally:
        client.comm_params.timeout_connect = short


async def read_si(client, name: str) -> float:
    ch = RIG.channel(name)
    if ch.kind == "input":
        rr = await client.read_input_registers(ch.address, count=ch.width, device_id=UNIT)
    elif ch.kind == "holding":
        rr = await client.read_holding_registers(ch.address, count=ch.width, device_id=UNIT)
    elif ch.kind == "coil":
        rr = await client.read_coils(ch.address, count=1, device_id=UNIT)
        return float(rr.bits[0])
    else:
        rr = await client.read_discrete_inputs(ch.address, count=1, device_id=UNIT)
        return float(rr.bits[0])
    assert not rr.isError(), rr
    return decode(ch, rr.registers)


async def _above(client, name: str, value: float) -> bool:
    return await read_si(client, name) > value


async def start_tow(client, kg: float) -> None:
    weight = RIG.channel("sim_tow_weight")
    rr = await client.write_registers(weight.address, encode(weight, kg), device_id=UNIT)
    assert not rr.isError()
    rr = await client.write_coil(RIG.channel("tow_release").address, True, device_id=UNIT)
    assert not rr.isError()


async def test_tcp_client_sees_tow_position_grow(plc):
    client = await tcp_client(await plc.start_tcp())
    try:
        assert await read_si(client, "sim_tow_weight") == 0.0
        await start_tow(client, 2.5)
        assert await read_si(client, "sim_tow_weight") == pytest.approx(2.5)
        assert await read_si(client, "tow_release") == 1.0
        positions = []
        for _ in range(5):
            await asyncio.sleep(0.1)  # readings spread over time: the position grows between
            positions.append(await read_si(client, "tow_position"))
        assert all(b > a for a, b in itertools.pairwise(positions)), positions
        assert await read_si(client, "supply_voltage") == pytest.approx(16.0, abs=0.2)
        assert await read_si(client, "load_cell") == pytest.approx(0.3, abs=0.3)
        loop = asyncio.get_running_loop()
        t_a = loop.time()
        beat0, clock0 = await read_si(client, "heartbeat"), await read_si(client, "plc_clock")
        t_b = loop.time()
        await asyncio.sleep(0.1)  # a known interval over which to count the heartbeat's ticks
        t_c = loop.time()
        beat1, clock1 = await read_si(client, "heartbeat"), await read_si(client, "plc_clock")
        t_d = loop.time()
        shortest, longest = t_c - t_b, t_d - t_a  # bounds on the time between the samples
        assert shortest / 0.01 - 2 <= beat1 - beat0 <= longest / 0.01 + 2  # +1 per 10 ms
        assert shortest - 0.002 <= clock1 - clock0 <= longest + 0.002
    finally:
        client.close()


async def test_rtu_over_a_pty(plc):
    client = await rtu_client(await plc.start_rtu_pty())
    try:
        await start_tow(client, 8.5)
        first = await read_si(client, "tow_position")
        await until(
            lambda: _above(client, "tow_position", first), "the vehicle moving", timeout_s=5
        )
        rr = await client.read_input_registers(0, count=10, device_id=UNIT)
        assert not rr.isError() and len(rr.registers) == 10
    finally:
        client.close()


async def test_rtu_over_a_socket_url(plc):
    url = await plc.start_rtu_tcp()
    assert url.startswith("socket://127.0.0.1:")
    client = await rtu_client(url)
    try:
        assert await read_si(client, "supply_voltage") == pytest.approx(16.0, abs=0.2)
    finally:
        client.close()


async def test_unknown_addresses_answer_illegal_address(plc):
    client = await tcp_client(await plc.start_tcp())
    try:
        for rr in (
            await client.read_input_registers(12, count=1, device_id=UNIT),
            await client.read_input_registers(10, count=3, device_id=UNIT),  # runs past the map
            await client.read_holding_registers(0, count=1, device_id=UNIT),
            await client.read_coils(5, count=1, device_id=UNIT),  # a gap inside a bit word
            await client.read_discrete_inputs(2, count=1, device_id=UNIT),
            await client.write_coil(3, True, device_id=UNIT),
        ):
            assert rr.isError() and rr.exception_code == 2, rr  # ILLEGAL_ADDRESS
    finally:
        client.close()


async def test_out_of_range_weight_is_refused(plc):
    client = await tcp_client(await plc.start_tcp())
    try:
        weight = RIG.channel("sim_tow_weight")
        rr = await client.write_registers(weight.address, encode(weight, 80.0), device_id=UNIT)
        assert rr.isError() and rr.exception_code == 3  # ILLEGAL_DATA_VALUE
        assert plc.plant.tow_weight_kg == 0.0
    finally:
        client.close()


async def test_sim_reset_and_thrust_stand_coils(plc):
    client = await tcp_client(await plc.start_tcp())
    try:
        await start_tow(client, 8.5)
        await until(lambda: _above(client, "tow_position", 0.0), "the vehicle moving", timeout_s=5)
        await client.write_coil(RIG.channel("sim_reset").address, True, device_id=UNIT)
        assert await read_si(client, "tow_position") == 0.0
        assert await read_si(client, "tow_release") == 0.0
        assert await read_si(client, "sim_reset") == 0.0  # self-clearing
        await client.write_coil(RIG.channel("sim_thrust_stand").address, True, device_id=UNIT)
        assert plc.plant.thrust_stand and await read_si(client, "sim_thrust_stand") == 1.0
    finally:
        client.close()


async def test_faults_drop_delay_and_corrupt(plc):
    client = await tcp_client(await plc.start_tcp(), timeout=0.15)
    loop = asyncio.get_running_loop()
    try:
        with patient(client):
            assert await read_si(client, "heartbeat") >= 0
        for fault in ("drop", "delay", "corrupt"):
            if fault == "drop":
                plc.faults.drop = True
            elif fault == "delay":
                plc.faults.delay_s = 0.4
            else:
                plc.faults.corrupt = True
            asked = loop.time()
            with pytest.raises(ModbusException):
                await client.read_input_registers(0, count=2, device_id=UNIT)
            plc.faults.clear()
            if fault == "delay":  # the answer comes 0.4 s after the request, unannounced:
                await asyncio.sleep(asked + 0.45 - loop.time())  # let it come and be discarded
            if not client.connected:
                client.close()
                assert await client.connect()
            with patient(client):
                rr = await client.read_input_registers(0, count=2, device_id=UNIT)
            assert not rr.isError(), f"no recovery after {fault}"
    finally:
        client.close()


async def test_corrupt_rtu_response_has_a_wrong_crc(plc):
    client = await rtu_client(await plc.start_rtu_pty(), timeout=0.2)
    try:
        plc.faults.corrupt = True
        with pytest.raises(ModbusException):
            await client.read_input_registers(0, count=2, device_id=UNIT)
        plc.faults.clear()
        with patient(client):
            rr = await client.read_input_registers(0, count=2, device_id=UNIT)
        assert not rr.isError()
    finally:
        client.close()


async def test_stop_server_and_restart_on_the_same_port(plc):
    port = await plc.start_tcp()
    client = await tcp_client(port, timeout=0.2)
    try:
        await plc.stop_server()
        with pytest.raises(ModbusException):
            await client.read_input_registers(0, count=2, device_id=UNIT)
        client.close()
        assert not await client.connect()
        await plc.start_server()
        assert plc.port == port
        assert await client.connect()
        with patient(client):
            rr = await client.read_input_registers(0, count=2, device_id=UNIT)
        assert not rr.isError()
    finally:
        client.close()


async def test_rtu_pty_server_restarts_on_the_same_path(plc):
    client = await rtu_client(await plc.start_rtu_pty(), timeout=0.2)
    try:
        await plc.stop_server()
        with pytest.raises(ModbusException):
            await client.read_input_registers(0, count=2, device_id=UNIT)
        await plc.start_server()
        with patient(client):
            rr = await client.read_input_registers(0, count=2, device_id=UNIT)
        assert not rr.isError()
    finally:
        client.close()


async def test_estop_reads_back_and_blocks_release(plc):
    client = await tcp_client(await plc.start_tcp())
    try:
        plc.plant.press_estop(True)
        assert await read_si(client, "estop") == 1.0
        await start_tow(client, 2.5)
        assert await read_si(client, "tow_release") == 0.0
        plc.plant.press_estop(False)
        await start_tow(client, 2.5)
        assert await read_si(client, "tow_release") == 1.0
    finally:
        client.close()


async def test_timestamp_jitter_spreads_response_times():
    from daq.sim.scenario import parse_scenario

    plant = Plant(RIG, parse_scenario({"sensors": {"timestamp_jitter_s": 0.03}, "seed": 4}))
    jittery = SimulatedPLC(RIG, plant)
    client = await tcp_client(await jittery.start_tcp())
    try:
        loop = asyncio.get_running_loop()
        latencies = []
        for _ in range(20):
            t0 = loop.time()
            rr = await client.read_input_registers(0, count=2, device_id=UNIT)
            assert not rr.isError()
            latencies.append(loop.time() - t0)
        # uniform 0…30 ms hold: the answers spread out and average ~15 ms
        assert max(latencies) - min(latencies) > 0.01
        assert sum(latencies) / len(latencies) > 0.008
    finally:
        client.close()
        await jittery.stop()
