"""Read planning from the register map, and host-side counter unwrapping."""

from __future__ import annotations

import pytest

from daq.blocks import MAX_REGISTERS_PER_READ, plan_blocks
from daq.config import Channel, load_rig
from daq.unwrap import CounterUnwrapper


def test_benbam_map_reads_in_one_request_per_kind():
    rig = load_rig()
    blocks = plan_blocks(c for c in rig.channels if not c.sim_only)
    spans = [(b.kind, b.start, b.count) for b in blocks]
    assert spans == [("input", 0, 12), ("discrete", 0, 2), ("coil", 0, 3)]
    assert [c.name for c in blocks[0].channels] == [
        "tow_position",
        "yaw_angle",
        "load_cell",
        "supply_voltage",
        "heartbeat",
        "plc_clock",
        "pendulum_angle",
    ]
    assert "input registers 0-11" in blocks[0].describe()


def test_gaps_are_never_bridged_and_kinds_are_separate():
    chans = [
        Channel(name="a", kind="holding", address=10, type="int32"),
        Channel(name="b", kind="holding", address=12),
        Channel(name="c", kind="holding", address=14),  # gap at 13
        Channel(name="d", kind="input", address=12),
        Channel(name="e", kind="coil", address=3, type="bool"),
        Channel(name="f", kind="coil", address=5, type="bool"),
    ]
    spans = [(b.kind, b.start, b.count, [c.name for c in b.channels]) for b in plan_blocks(chans)]
    assert spans == [
        ("input", 12, 1, ["d"]),
        ("holding", 10, 3, ["a", "b"]),
        ("holding", 14, 1, ["c"]),
        ("coil", 3, 1, ["e"]),
        ("coil", 5, 1, ["f"]),
    ]


def test_long_runs_split_at_the_modbus_request_limit():
    chans = [Channel(name=f"r{i}", kind="input", address=i, type="int32") for i in range(0, 300, 2)]
    blocks = plan_blocks(chans)
    assert all(b.count <= MAX_REGISTERS_PER_READ for b in blocks)
    assert sum(b.count for b in blocks) == 300
    assert [c.name for b in blocks for c in b.channels] == [c.name for c in chans]


def test_uint16_heartbeat_unwraps_across_65535_to_0():
    u = CounterUnwrapper(65536)
    seen = [u.update(raw) for raw in (65530, 65534, 65535, 0, 3, 30000, 60000, 10)]
    assert seen == [65530, 65534, 65535, 65536, 65539, 95536, 125536, 131082]


def test_uint32_clock_unwraps_and_small_backward_steps_stay_backward():
    period = 2**32
    u = CounterUnwrapper(period)
    assert u.update(period - 5) == period - 5
    assert u.update(7) == period + 7
    assert u.update(3) == period + 3  # a small step back is not a wrap forwards
    u.reset()
    assert u.update(42) == 42


def test_unwrapper_rejects_a_meaningless_period():
    with pytest.raises(ValueError, match="period"):
        CounterUnwrapper(1)
