"""Framing, CRC and sequence arithmetic of the thruster line protocol."""

from __future__ import annotations

import pytest

from thrusters import protocol as p


def test_crc_is_ccitt_false_check_value() -> None:
    assert p.crc16(b"123456789") == 0x29B1


def test_documented_frames_are_byte_exact() -> None:
    assert p.thr_frame(7, [100, 0]) == b"$THR,7,100,0*4867\r\n"
    assert p.ack_frame(7, "ARMED") == b"$ACK,7,ARMED*4236\r\n"
    assert p.nak_frame(None, "crc") == b"$NAK,-,crc*8C80\r\n"


def test_parse_round_trip_and_leading_noise_ignored() -> None:
    frame = p.parse_frame(b"\x00\xff$" + p.thr_frame(42, [-1000, 1000])[1:])
    assert frame.kind == "THR" and frame.fields == ("42", "-1000", "1000")
    assert p.frame_seq(frame) == 42


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        (b"$THR,7,100,0*4868\r\n", "crc"),
        (b"$THR,7,100,0*4867".replace(b"100", b"101") + b"\r\n", "crc"),
        (b"THR,7,100,0*4867\r\n", "malformed"),
        (b"$THR,7,100,0\r\n", "malformed"),
        (b"$THR,7,100,0*48g7\r\n", "malformed"),
        (b"$NAK,-,crc*8c80\r\n", "malformed"),
    ],
)
def test_bad_frames_raise_with_reason(line: bytes, reason: str) -> None:
    with pytest.raises(p.ProtocolError) as err:
        p.parse_frame(line)
    assert err.value.reason == reason


def test_crc_error_still_reports_readable_seq() -> None:
    with pytest.raises(p.ProtocolError) as err:
        p.parse_frame(b"$THR,9,1,2*0000")
    assert err.value.reason == "crc" and err.value.seq == 9


def test_unknown_kind_and_bad_seq_are_malformed() -> None:
    for body in ("FOO,1", "THR,-1,0", "THR,65536,0", "THR,x,0", "ARM"):
        with pytest.raises(p.ProtocolError, match="malformed"):
            p.parse_frame(p.encode_frame(body))


def test_seq_newer_wraps() -> None:
    assert p.seq_is_newer(1, 0)
    assert p.seq_is_newer(0, 65535)
    assert not p.seq_is_newer(5, 5)
    assert not p.seq_is_newer(4, 5)
    assert not p.seq_is_newer(65535, 0)
    assert p.next_seq(65535) == 0


def test_command_conversion_validates() -> None:
    assert p.fraction_to_command(0.1234) == 123
    assert p.fraction_to_command(-1.0) == -1000
    for bad in (float("nan"), float("inf"), 1.01):
        with pytest.raises(ValueError, match="thruster 3"):
            p.fraction_to_command(bad, 3)
    with pytest.raises(ValueError, match=r"thruster 1.*1001"):
        p.thr_frame(1, [0, 1001])


def test_parse_replies() -> None:
    assert p.parse_reply(b"$ACK,7,ARMED*4236\r\n") == p.Reply("ACK", 7, state="ARMED")
    assert p.parse_reply(p.nak_frame(3, "stale")).reason == "stale"
    assert p.parse_reply(p.nak_frame(None, "crc")).seq is None
    sta = p.parse_reply(p.sta_frame(3, "WDT", [(1200.4, 1.234), (-5, 0.0)]))
    assert sta.state == "WDT" and sta.rpm == (1200.0, -5.0) and sta.current_a == (1.23, 0.0)
    with pytest.raises(p.ProtocolError):
        p.parse_reply(p.encode_frame("ACK,1,HAPPY"))
    with pytest.raises(p.ProtocolError):
        p.parse_reply(b"$NAK,-,crc*0000\r\n")


def test_every_example_in_the_protocol_doc_checks_out() -> None:
    import re
    from pathlib import Path

    doc = Path(__file__).resolve().parents[2] / "docs" / "thruster-protocol.md"
    frames = re.findall(r"\$[A-Z]+,[^\s*]*\*[0-9A-F]{4}\\r\\n", doc.read_text())
    assert len(frames) >= 18
    for text in frames:
        raw = text.replace("\\r\\n", "\r\n").encode()
        if raw.endswith(b"*0000\r\n"):  # the deliberately corrupted example
            with pytest.raises(p.ProtocolError, match="crc"):
                p.parse_frame(raw)
        elif raw.startswith(b"$NAK,-"):
            assert p.parse_reply(raw).seq is None
        else:
            assert p.encode_frame(raw[1:-7].decode()) == raw
