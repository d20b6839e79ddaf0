"""Byte-exact conversations between ThrusterDriver and a scripted controller.

Each runs in memory (``ExpectedProtocol``: no pty, no real waiting for timeouts); a few
also run over a real pty (``ScriptedPeer``) so the serial path itself stays covered."""

from __future__ import annotations

import pytest
from thruster_helpers import (
    Conversation,
    ExpectedProtocol,
    FakeClock,
    ScriptedPeer,
    limits,
    thruster_port,
)

from thrusters import protocol as p
from thrusters.driver import OPEN_QUERY_ATTEMPTS, ThrusterDriver, ThrusterError

STA_IDLE = p.sta_frame(1, "DISARMED", [(0, 0), (0, 0)])

#: Tests that also run over a real pty.
BOTH = pytest.mark.parametrize("transport", ["memory", "pty"])


@pytest.fixture
def transport() -> str:
    return "memory"


def controller(transport: str, conversation: Conversation) -> ExpectedProtocol | ScriptedPeer:
    if transport == "memory":
        return ExpectedProtocol(conversation)
    return ScriptedPeer(conversation)


@BOTH
async def test_arm_ramp_clamp_zero_and_close(transport: str) -> None:
    peer = controller(
        transport,
        [
            (b"$QRY,1*939A\r\n", STA_IDLE),
            (b"$ARM,2*3800\r\n", b"$ACK,2,ARMED*3B91\r\n"),
            # 0.1 s later: slew 2.0 /s lets the command move 0.2 toward ±0.5.
            (b"$THR,3,200,-200*F9D3\r\n", b"$ACK,3,ARMED*83F0\r\n"),
            (b"$THR,4,400,-400*D742\r\n", b"$ACK,4,ARMED*9AB4\r\n"),
            (b"$THR,5,500,-500*C8E4\r\n", b"$ACK,5,ARMED*22D5\r\n"),
            # 1.5 is clamped to 0.8 (the rig limit); both ramp by at most 0.2 per 0.1 s.
            (b"$THR,6,700,-300*442D\r\n", b"$ACK,6,ARMED*FA57\r\n"),
            (b"$THR,7,0,0*7714\r\n", b"$ACK,7,ARMED*4236\r\n"),
            # close(): zero again, then disarm.
            (b"$THR,8,0,0*12ED\r\n", b"$ACK,8,ARMED*C8DF\r\n"),
            (b"$DISARM,9*18B0\r\n", b"$ACK,9,DISARMED*5B7A\r\n"),
        ],
    )
    clock = FakeClock()
    drv = peer.driver(clock=clock)
    async with drv:
        assert drv.state == "DISARMED"
        await drv.arm()
        clock.t += 0.1
        assert await drv.command([0.5, -0.5])
        clock.t += 0.1
        assert await drv.heartbeat()
        clock.t += 0.1
        assert await drv.heartbeat()
        assert drv.output == [0.5, -0.5]
        clock.t += 0.5  # a long pause still only credits 0.1 s of slew
        assert await drv.command([1.5, -0.1])
        assert drv.clamped_commands == 1
        assert await drv.zero()
    peer.assert_done()
    assert drv.stats.sent == 9 and drv.stats.acked == 8 and drv.stats.queries_answered == 1
    assert not drv.is_open


async def test_nan_and_wrong_count_are_refused_before_anything_is_sent(transport: str) -> None:
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "ARMED", [(0, 0)] * 2)),
            (p.thr_frame(2, [0, 0]), p.ack_frame(2, "ARMED")),
            (p.disarm_frame(3), p.ack_frame(3, "DISARMED")),
        ],
    )
    async with peer.driver() as drv:
        with pytest.raises(ValueError, match=r"thruster 1: .*nan"):
            await drv.command([0.1, float("nan")])
        with pytest.raises(ValueError, match=r"thruster 0: .*inf"):
            await drv.command([float("-inf"), 0.0])
        with pytest.raises(ValueError, match=r"one value per thruster \(2\) needed, got 3"):
            await drv.command([0.1, 0.1, 0.1])
    peer.assert_done()


@BOTH
async def test_zero_retries_through_silence_garbage_and_corruption(transport: str) -> None:
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "ARMED", [(0, 0)] * 2)),
            (p.thr_frame(2, [0, 0]), None),  # silent: timeout, retry
            (p.thr_frame(3, [0, 0]), b"\x00\xffnoise\r\n$ACK,3,ARMED*0000\r\n"),
            (p.thr_frame(4, [0, 0]), p.ack_frame(3, "ARMED") + p.ack_frame(4, "ARMED")),
        ],
    )
    drv = peer.driver()
    await drv.open()
    assert await drv.zero(retries=3)
    s = drv.stats
    assert (s.timeouts, s.garbage_lines, s.corrupt_lines, s.unexpected_replies) == (2, 1, 1, 1)
    await drv._close_port()
    peer.assert_done()


async def test_zero_gives_up_after_retries_when_silent(transport: str) -> None:
    peer = controller(
        transport,
        [(p.qry_frame(1), p.sta_frame(1, "ARMED", [(0, 0)] * 2))]
        + [(p.thr_frame(seq, [0, 0]), None) for seq in (2, 3)],
    )
    drv = peer.driver()
    await drv.open()
    assert not await drv.zero(retries=1)
    assert drv.stats.timeouts == 2
    await drv._close_port()
    peer.assert_done()


async def test_zero_on_a_link_already_lost_puts_one_frame_on_the_line_per_call(
    transport: str,
) -> None:
    """Two heartbeats unanswered: the link is lost and the driver sends its zero at once.
    A zero asked for after that sends one frame, not four; while the link still answered,
    the same silence was retried (test above)."""
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "ARMED", [(0, 0)] * 2)),
            (p.thr_frame(2, [0, 0]), None),
            (p.thr_frame(3, [0, 0]), None),  # the second miss: link lost
            (p.thr_frame(4, [0, 0]), None),  # the zero put on the line at the loss
            (p.thr_frame(5, [0, 0]), None),  # zero(retries=3): one frame, no retry
            (p.thr_frame(6, [0, 0]), p.ack_frame(6, "ARMED")),  # the line back: ACKed
        ],
    )
    drv = peer.driver()
    await drv.open()
    assert not await drv.heartbeat()
    assert not await drv.heartbeat()
    assert drv.fault is not None and drv.fault.kind == "link_lost"
    assert not await drv.zero(retries=3)
    assert drv.stats.timeouts == 4
    assert await drv.zero(retries=3)  # a reply again: zero is confirmed
    await drv._close_port()
    peer.assert_done()


async def test_zero_counts_nak_disarmed_as_done_and_falls_back_to_disarm_on_stale(
    transport: str,
) -> None:
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "WDT", [(0, 0)] * 2)),
            (p.thr_frame(2, [0, 0]), p.nak_frame(2, "disarmed")),
            (p.thr_frame(3, [0, 0]), p.nak_frame(3, "stale")),
            (p.thr_frame(4, [0, 0]), p.nak_frame(4, "stale")),
            (p.disarm_frame(5), p.ack_frame(5, "DISARMED")),
        ],
    )
    drv = peer.driver()
    await drv.open()
    assert drv.state == "WDT"
    assert await drv.zero()
    assert await drv.zero(retries=1)
    assert dict(drv.stats.naks) == {"disarmed": 1, "stale": 2}
    await drv._close_port()
    peer.assert_done()


async def test_arm_refused_raises_and_query_reports_telemetry(transport: str) -> None:
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "DISARMED", [(0, 0)] * 2)),
            (p.arm_frame(2), p.nak_frame(2, "crc")),
            (
                p.qry_frame(3),
                b"$STA,3,ARMED,1500,-1200,2.50,1.75*"
                + b"%04X\r\n" % p.crc16(b"STA,3,ARMED,1500,-1200,2.50,1.75"),
            ),
        ],
    )
    drv = peer.driver()
    await drv.open()
    with pytest.raises(ThrusterError, match=r"arm: .*NAK crc"):
        await drv.arm()
    status = await drv.query()
    assert status.state == "ARMED"
    assert status.rpm == (1500.0, -1200.0) and status.current_a == (2.5, 1.75)
    await drv._close_port()
    peer.assert_done()


async def test_stale_sensor_hook_holds_zero_until_released(transport: str) -> None:
    clock = FakeClock()
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "DISARMED", [(0, 0)] * 2)),
            (p.arm_frame(2), p.ack_frame(2, "ARMED")),
            (p.thr_frame(3, [200, 200]), p.ack_frame(3, "ARMED")),
            (p.thr_frame(4, [0, 0]), p.ack_frame(4, "ARMED")),  # zero_on_stale(True)
            (p.thr_frame(5, [0, 0]), p.ack_frame(5, "ARMED")),  # command while stale
            (p.thr_frame(6, [200, 200]), p.ack_frame(6, "ARMED")),  # fresh again: ramps
        ],
    )
    drv = peer.driver(clock=clock)
    await drv.open()
    await drv.arm()
    clock.t += 0.1
    await drv.command([0.6, 0.6])
    await drv.zero_on_stale(True)
    clock.t += 0.1
    await drv.command([0.6, 0.6])
    await drv.zero_on_stale(True)  # still stale: nothing more sent
    await drv.zero_on_stale(False)
    clock.t += 0.1
    await drv.command([0.6, 0.6])
    await drv._close_port()
    peer.assert_done()


async def test_open_fails_clearly_without_a_controller() -> None:
    with pytest.raises(ThrusterError, match="cannot open '/dev/nonexistent-thr'"):
        await ThrusterDriver(thruster_port("/dev/nonexistent-thr"), limits()).open()
    with pytest.raises(ValueError, match=r"thrusters\.port: 'sim'"):
        ThrusterDriver(thruster_port("sim"), limits())


@BOTH
async def test_overlong_noise_glued_to_a_reply_is_dropped_and_the_reply_kept(
    transport: str,
) -> None:
    """Line noise without a line end, then the ACK in the same read: one garbage count,
    the ACK still answers (not a timeout), however the bytes were split into reads."""
    noise = b"\x00noise without end " * 20  # longer than protocol.MAX_LINE_BYTES
    peer = controller(
        transport,
        [
            (p.qry_frame(1), p.sta_frame(1, "ARMED", [(0, 0)] * 2)),
            (p.thr_frame(2, [0, 0]), noise + p.ack_frame(2, "ARMED")),
            (p.thr_frame(3, [0, 0]), p.ack_frame(3, "ARMED")),
            (p.disarm_frame(4), p.ack_frame(4, "DISARMED")),
        ],
    )
    async with peer.driver() as drv:
        assert await drv.heartbeat()
        assert drv.stats.garbage_lines == 1 and drv.stats.timeouts == 0
    peer.assert_done()


async def test_close_sends_nothing_to_a_controller_that_was_never_armed(
    caplog, transport: str
) -> None:
    """A weight-driven run opens the driver (query) and closes it: the controller said
    DISARMED, so no zero (which would earn a ``NAK disarmed``) and no DISARM are sent."""
    peer = controller(transport, [(p.qry_frame(1), STA_IDLE)])
    async with peer.driver() as drv:
        assert drv.state == "DISARMED"
    peer.assert_done()
    assert drv.stats.sent == 1 and not drv.stats.naks
    assert "NAK" not in caplog.text


async def test_close_still_zeroes_when_an_arm_went_unanswered(transport: str) -> None:
    """An ARM that timed out may have armed the controller: close zeroes and disarms."""
    peer = controller(
        transport,
        [
            (p.qry_frame(1), STA_IDLE),
            (p.arm_frame(2), None),
            (p.thr_frame(3, [0, 0]), p.ack_frame(3, "ARMED")),
            (p.disarm_frame(4), p.ack_frame(4, "DISARMED")),
        ],
    )
    async with peer.driver() as drv:
        with pytest.raises(ThrusterError, match="arm"):
            await drv.arm()
        assert drv.state == "DISARMED"  # what it last said, not what it may be now
    peer.assert_done()


async def test_in_memory_silence_costs_the_reply_timeout_on_the_links_clock() -> None:
    """A silent controller makes the link wait its full ack_timeout_s for each opening
    query, counted on the in-memory clock rather than slept."""
    attempts = OPEN_QUERY_ATTEMPTS
    peer = ExpectedProtocol([(p.qry_frame(seq), None) for seq in range(1, attempts + 1)])
    drv = peer.driver()
    with pytest.raises(ThrusterError, match=r"query: controller at .* gave no reply"):
        await drv.open()
    assert drv.stats.timeouts == attempts
    assert peer.t >= attempts * thruster_port(peer.url).ack_timeout_s
    peer.assert_done()


@BOTH
async def test_a_controller_that_misses_the_first_query_after_the_open_is_asked_again(
    transport: str,
) -> None:
    """A board that resets when its port opens (or a loaded host) misses the first frame:
    the opening query is asked again, and the link opens."""
    peer = controller(
        transport,
        [
            (p.qry_frame(1), None),
            (p.qry_frame(2), p.sta_frame(2, "DISARMED", [(0, 0), (0, 0)])),
        ],
    )
    drv = peer.driver()
    await drv.open()
    assert drv.state == "DISARMED" and drv.stats.timeouts == 1
    await drv._close_port()
    peer.assert_done()


async def test_a_wrong_answer_to_the_opening_query_is_not_asked_again() -> None:
    peer = ExpectedProtocol([(p.qry_frame(1), p.sta_frame(1, "DISARMED", [(0, 0)] * 3))])
    with pytest.raises(ThrusterError, match=r"reports 3 thrusters, rig file thrusters\.count"):
        await peer.driver().open()
    peer.assert_done()


async def test_in_memory_controller_rejects_bytes_it_did_not_expect() -> None:
    """The in-memory controller fails the test on the first wrong byte, naming the step."""
    peer = ExpectedProtocol([(p.arm_frame(1), p.ack_frame(1, "ARMED"))])
    drv = peer.driver()
    with pytest.raises(AssertionError, match=r"step 0: expected b'\$ARM,1"):
        await drv.open()
    await drv._close_port()
    with pytest.raises(AssertionError, match="step 0"):
        peer.assert_done()
