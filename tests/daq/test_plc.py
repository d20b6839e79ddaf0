"""PlcClient against a real pymodbus server on a real TCP socket."""

from __future__ import annotations

import asyncio
import math
import socket
import time

import pytest

from daq.config import ModbusConnection, load_rig
from daq.plc import WRITE_WITHIN_S, DeviceError, PlcClient
from daq.sample import Quality
from daq.session import RigSession, RigSource
from daq.store import Store
from daq.vocabulary import AXES
from tests.daq.modbus_server import MapServer
from tests.support.waiting import until


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


async def test_read_all_decodes_every_channel_in_si(server, plc):
    server.set("tow_position", -1.23456)
    server.set("yaw_angle", 3.14159)
    server.set("load_cell", -83.3)  # little word order on BENBAM
    server.set("supply_voltage", 24.37)
    server.set("end_of_travel", True)
    server.set("tow_release", True)
    readings = await plc.read_all()
    assert set(readings) == {c.name for c in plc.rig.channels if not c.sim_only}
    assert readings["tow_position"].value == pytest.approx(-1.23456, abs=1e-5)
    assert readings["yaw_angle"].value == pytest.approx(3.14159, abs=1e-5)
    assert readings["load_cell"].value == pytest.approx(-83.3, abs=1e-3)
    assert readings["supply_voltage"].value == pytest.approx(24.37, abs=0.005)
    assert readings["end_of_travel"].value == 1.0
    assert readings["estop"].value == 0.0
    assert readings["tow_release"].value == 1.0
    assert all(r.quality == Quality.OK for r in readings.values())
    assert plc.stats.reads == 3  # one request per kind: input 0-11, discrete 0-1, coil 0-2


@pytest.mark.parametrize("order", ["big", "little"])
async def test_32_bit_word_order_both_ways(order):
    rig = load_rig()
    chans = [
        c.model_copy(update={"word_order": order}) if c.name == "tow_position" else c
        for c in rig.channels
    ]
    srv = MapServer(rig.model_copy(update={"channels": chans}))
    await srv.start()
    try:
        srv.words["input"][0], srv.words["input"][1] = 0x0001, 0x0002
        client = PlcClient(srv.rig_config())
        await client.connect(timeout_s=2.0)
        raw = 0x00010002 if order == "big" else 0x00020001
        assert await client.read("tow_position") == pytest.approx(raw * 1e-5)
        await client.close()
    finally:
        await srv.stop()


async def test_heartbeat_and_plc_clock_unwrap_on_the_wire(server, plc):
    server.heartbeat_running = False
    server.set_raw("heartbeat", 65534)
    server.set_raw("plc_clock", 2**32 - 2)  # ms
    first = await plc.read_all()
    server.set_raw("heartbeat", 65536 + 5)  # wraps to 5 on the wire
    server.set_raw("plc_clock", 2**32 + 3)
    second = await plc.read_all()
    assert second["heartbeat"].value - first["heartbeat"].value == 7
    assert second["plc_clock"].value - first["plc_clock"].value == pytest.approx(0.005)
    assert second["plc_clock"].value == pytest.approx((2**32 + 3) * 1e-3)


async def test_a_counter_that_stops_counting_goes_stale(server):
    rig = server.rig_config()
    chans = [c.model_copy(update={"freshness_s": 0.1}) for c in rig.channels]
    plc = PlcClient(rig.model_copy(update={"channels": chans}))
    await plc.connect(timeout_s=2.0)
    server.heartbeat_running = False
    try:
        server.set_raw("heartbeat", 10)
        assert (await plc.read_all())["heartbeat"].quality == Quality.OK
        await asyncio.sleep(0.15)  # heartbeat frozen for longer than freshness_s
        frozen = await plc.read_all()
        assert frozen["heartbeat"].quality == Quality.STALE
        assert frozen["tow_position"].quality == Quality.OK  # read fresh; it may not move
        server.set_raw("heartbeat", 11)
        assert (await plc.read_all())["heartbeat"].quality == Quality.OK
    finally:
        await plc.close()


async def test_an_exception_response_flags_only_that_block(server, plc):
    await plc.read_all()
    server.fail_reads = True
    with pytest.raises(DeviceError, match=r"input registers 0-11 \(tow_position"):
        await plc.read_all()  # every block failed -> raises
    assert plc.connected
    server.fail_reads = False
    assert all(r.quality == Quality.OK for r in (await plc.read_all()).values())


async def test_write_by_name_coils_and_sim_only_holding(server, plc):
    await plc.write("tow_release", True)
    assert server.get("tow_release") == 1.0
    await plc.write("sim_tow_weight", 2.5)  # kg -> 2500 g in a uint32, sim_only allowed
    assert server.get("sim_tow_weight") == pytest.approx(2.5)
    assert await plc.read("sim_tow_weight") == pytest.approx(2.5)
    await plc.write("tow_release", False)
    assert await plc.read("tow_release") == 0.0


async def test_bad_writes_name_the_channel_value_and_range(plc):
    with pytest.raises(ValueError, match=r"'sim_tow_weight'.*-1.0.*allowed 0.0\.\."):
        await plc.write("sim_tow_weight", -1.0)
    with pytest.raises(ValueError, match="finite"):
        await plc.write("sim_tow_weight", math.nan)
    with pytest.raises(ValueError, match="true/false"):
        await plc.write("tow_release", 2)
    with pytest.raises(DeviceError, match="read-only"):
        await plc.write("estop", True)
    with pytest.raises(KeyError, match="no channel 'warp_drive'"):
        await plc.write("warp_drive", 1.0)


async def test_first_connect_does_not_retry():
    rig = load_rig()
    rig = rig.model_copy(update={"modbus": rig.modbus.model_copy(update={"port": _free_port()})})
    plc = PlcClient(rig)
    t0 = time.monotonic()
    with pytest.raises(DeviceError, match=r"cannot connect to PLC at tcp 127.0.0.1:\d+ unit 1"):
        await plc.connect()
    assert time.monotonic() - t0 < 0.5
    await plc.close()


async def test_connect_with_timeout_retries_until_the_server_appears():
    srv = MapServer(load_rig(), port=_free_port())
    plc = PlcClient(srv.rig_config(reconnect_min_s=0.05, reconnect_max_s=0.2))

    async def late_start():
        await asyncio.sleep(0.3)  # the server away for a while: the first attempts must fail
        await srv.start()

    starter = asyncio.create_task(late_start())
    try:
        await plc.connect(timeout_s=3.0)
        assert plc.connected
        await plc.read_all()
    finally:
        await starter
        await plc.close()
        await srv.stop()


async def test_connect_timeout_gives_up_with_device_error():
    srv = MapServer(load_rig(), port=_free_port())
    plc = PlcClient(srv.rig_config(reconnect_min_s=0.05, reconnect_max_s=0.1))
    t0 = time.monotonic()
    with pytest.raises(DeviceError, match=r"attempt\(s\) in 0.4 s"):
        await plc.connect(timeout_s=0.4)
    assert 0.35 < time.monotonic() - t0 < 1.0
    await plc.close()


async def test_opening_a_rig_retries_a_refusing_plc_for_the_rig_files_connect_timeout(
    tmp_path, monkeypatch
):
    """``[modbus] connect_timeout_s`` (3 s by default, README and docs/acquisition.md)
    bounds how long opening a session retries a PLC that refuses connections; then one
    DeviceError naming the endpoint and the rig-file settings."""
    assert ModbusConnection().connect_timeout_s == load_rig().modbus.connect_timeout_s == 3.0
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path))  # the rig lock's folder
    rig = load_rig()
    closed = _free_port()  # nothing listens there: connections are refused
    modbus = rig.modbus.model_copy(
        update={"port": closed, "connect_timeout_s": 0.4, "reconnect_max_s": 0.1}
    )
    hardware = rig.rig.model_copy(update={"mode": "hardware"})
    source = RigSource(rig=rig.model_copy(update={"modbus": modbus, "rig": hardware}), rig_toml="")
    with Store(f"sqlite:///{tmp_path / 'rig.db'}") as store:
        t0 = time.monotonic()
        with pytest.raises(DeviceError, match=rf"127.0.0.1:{closed} .*attempt\(s\) in 0.4 s"):
            async with RigSession(source, store):
                pass
        assert 0.35 < time.monotonic() - t0 < 3.0  # its own limit, not the default's


async def test_server_lost_then_back_reconnects_in_the_background(server):
    plc = PlcClient(server.rig_config(reconnect_min_s=0.05, reconnect_max_s=0.2))
    await plc.connect(timeout_s=2.0)
    try:
        server.set("tow_position", 0.5)
        await plc.read_all()
        await server.stop()
        await until(lambda: not plc.connected, "the client seeing the server gone", timeout_s=2)
        t0 = time.monotonic()
        with pytest.raises(DeviceError, match="tow_position"):
            await plc.read_all()
        assert time.monotonic() - t0 < 0.3  # fails fast: no inline reconnect loop
        assert not plc.connected
        await asyncio.sleep(0.3)  # the server away while the background attempts fail
        await server.start()  # same port
        # the transport reports connected inside pymodbus' connect(), one loop turn before
        # the background loop gets its answer and counts the reconnect: wait for both
        await until(
            lambda: plc.connected and plc.stats.reconnects > 0,
            "reconnected in the background",
            timeout_s=2,
        )
        assert plc.stats.reconnects == 1
        assert (await plc.read_all())["tow_position"].value == pytest.approx(0.5)
    finally:
        await plc.close()


async def test_a_late_reply_costs_its_poll_not_the_link(server):
    """A reply after ``timeout_s`` fails that poll only: the link stays up without a
    reconnect (pymodbus drops the late reply's transaction), and the next poll reads what
    the PLC holds then, not the late reply."""
    # 0.5 s, not the default 0.05 s: a loaded host's hiccup must not fail the next poll too
    # (the server answers from this test's own loop; the late reply comes after 1 s)
    plc = PlcClient(server.rig_config(timeout_s=0.5))
    await plc.connect(timeout_s=2.0)
    try:
        server.set("tow_position", 0.25)
        server.slow_reads, server.slow_read_s = 1, 1.0  # the next read's reply comes late
        with pytest.raises(DeviceError, match="input registers 0-11"):
            await plc.read_all()
        await until(lambda: server.late_replies == 1, "the late reply sent", timeout_s=2)
        server.set("tow_position", 0.75)
        readings = await plc.read_all()
        assert readings["tow_position"].value == pytest.approx(0.75)
        assert all(r.quality == Quality.OK for r in readings.values())
        assert plc.connected and plc.stats.reconnects == 0 and plc.stats.errors == 1
    finally:
        await plc.close()


async def test_a_write_whose_reply_is_late_is_sent_again(server, plc):
    server.slow_writes = 1  # the first reply comes 0.2 s late (timeout_s = 0.05 s)
    await plc.write("tow_release", True)
    assert server.get("tow_release") == 1.0 and plc.stats.errors == 1


async def test_a_write_that_never_gets_a_reply_in_time_fails_naming_its_tries(server, plc):
    server.slow_writes = 1000
    # No reply while the client tries: a late one taken for a later try's (a loaded host
    # stretches the tries) would be a reply, not "never in time".
    server.slow_write_s = 5.0
    t0 = time.monotonic()
    with pytest.raises(DeviceError, match=r"write of 'tow_release'.*\((\d+) tries in 1 s\)") as err:
        await plc.write("tow_release", True)
    assert WRITE_WITHIN_S - 0.1 < time.monotonic() - t0 < WRITE_WITHIN_S + 1.0
    tries = int(err.value.args[0].rsplit("(", 1)[1].split()[0])
    assert tries >= 3 and plc.stats.errors >= tries  # each request that got no reply counted


async def test_a_write_waits_out_a_reconnect(server):
    """A write that finds the link down (pymodbus drops it after a few timeouts in a row)
    waits for the background reconnect instead of failing at once."""
    plc = PlcClient(server.rig_config(reconnect_min_s=0.05, reconnect_max_s=0.1))
    await plc.connect(timeout_s=2.0)
    try:
        await server.stop()
        await until(lambda: not plc.connected, "the client seeing the server gone", timeout_s=2)
        write = asyncio.ensure_future(plc.write("tow_release", True))
        # still trying half its time later, the link down all along (it used to fail at once)
        done, _ = await asyncio.wait({write}, timeout=WRITE_WITHIN_S / 2)
        assert not done and plc.stats.reconnects == 0
        await server.start()  # same port
        await asyncio.wait_for(write, WRITE_WITHIN_S + 1.0)
        assert server.get("tow_release") == 1.0 and plc.stats.reconnects == 1
    finally:
        await plc.close()


def test_a_write_rides_through_any_stall_a_run_tolerates():
    """A write keeps trying longer than the longest hole a run tolerates in its samples."""
    tolerances = [t.loss_tolerance_s for t in AXES.values() if t.loss_tolerance_s is not None]
    assert tolerances and max(tolerances) < WRITE_WITHIN_S


async def test_a_slow_plc_times_out_after_the_configured_timeout(server, plc):
    server.delay_s = 1.0  # 20× timeout_s = 0.05 s
    reads, errors = plc.stats.reads, plc.stats.errors
    t0 = time.monotonic()
    with pytest.raises(DeviceError, match="input registers 0-11"):
        await plc.read_all()
    elapsed = time.monotonic() - t0
    # one request timed out and the other blocks of the poll were not attempted (counted,
    # not timed: a loaded machine runs the loop late); the reply was not waited for (a
    # bound with room for that lateness)
    assert (plc.stats.errors - errors, plc.stats.reads - reads) == (1, 0)
    assert elapsed < server.delay_s / 2
    assert plc.stats.errors == 1
