"""Thruster line protocol: framing, CRC, sequence numbers (pure functions, no I/O).

A frame is one ASCII line ``$<BODY>*<CRC>\\r\\n``; ``CRC`` is CRC-16/CCITT-FALSE
(``binascii.crc_hqx(body, 0xFFFF)``) of the bytes between ``$`` and ``*``, written as
4 uppercase hex digits. The full specification with byte-exact examples is
``docs/thruster-protocol.md``.
"""

from __future__ import annotations

import binascii
import math
from dataclasses import dataclass

#: Commands are integers in per mille of full thrust.
COMMAND_MIN = -1000
COMMAND_MAX = 1000
SEQ_MODULO = 65536
#: Longest line either side accepts (longer input is discarded as garbage).
MAX_LINE_BYTES = 256

STATES = ("DISARMED", "ARMED", "WDT")
NAK_REASONS = ("crc", "range", "stale", "disarmed", "malformed")
HOST_KINDS = ("THR", "ARM", "DISARM", "QRY")
REPLY_KINDS = ("ACK", "NAK", "STA")


class ProtocolError(ValueError):
    """A line is not a valid frame. ``reason`` is a NAK reason; ``seq`` is the
    frame's sequence number when it could be read, else None."""

    def __init__(self, reason: str, detail: str, seq: int | None = None) -> None:
        super().__init__(f"{reason}: {detail}")
        self.reason = reason
        self.detail = detail
        self.seq = seq


@dataclass(frozen=True, slots=True)
class Frame:
    """A parsed frame: ``kind`` (``THR``, ``ACK``, …) and the comma-separated fields after it."""

    kind: str
    fields: tuple[str, ...]

    @property
    def body(self) -> str:
        return ",".join((self.kind, *self.fields))


@dataclass(frozen=True, slots=True)
class Reply:
    """A controller reply. ``kind`` is ``ACK``, ``NAK`` or ``STA``; ``seq`` is None only
    for a NAK answering a frame whose sequence number was unreadable."""

    kind: str
    seq: int | None
    state: str | None = None
    reason: str | None = None
    rpm: tuple[float, ...] = ()
    current_a: tuple[float, ...] = ()


def crc16(body: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): ``crc16(b"123456789") == 0x29B1``."""
    return binascii.crc_hqx(body, 0xFFFF)


def encode_frame(body: str) -> bytes:
    """``"ACK,7,ARMED"`` → ``b"$ACK,7,ARMED*<CRC>\\r\\n"``."""
    raw = body.encode("ascii")
    if any(c in raw for c in b"$*\r\n"):
        raise ValueError(f"frame body must not contain '$', '*', CR or LF, got {body!r}")
    return b"$" + raw + b"*" + f"{crc16(raw):04X}".encode() + b"\r\n"


def _seq_of(fields: list[str]) -> int | None:
    if len(fields) < 2:
        return None
    try:
        seq = int(fields[1])
    except ValueError:
        return None
    return seq if 0 <= seq < SEQ_MODULO and fields[1].isdigit() else None


def parse_frame(line: bytes) -> Frame:
    """Parse one line (with or without CR/LF). Bytes before the last ``$`` are ignored.

    Raises ProtocolError with reason ``malformed`` (no ``$``/``*``, bad CRC digits,
    non-ASCII, empty body or unknown kind) or ``crc`` (checksum mismatch).
    """
    text = line.rstrip(b"\r\n")
    start = text.rfind(b"$")
    if start < 0:
        raise ProtocolError("malformed", f"no '$' in line {line[:40]!r}")
    text = text[start + 1 :]
    body, star, crc_text = text.partition(b"*")
    fields_guess = body.decode("ascii", "replace").split(",")
    seq_guess = _seq_of(fields_guess)
    if not star:
        raise ProtocolError("malformed", f"no '*' before the CRC in {line[:40]!r}", seq_guess)
    if len(crc_text) != 4 or any(c not in b"0123456789ABCDEF" for c in crc_text):
        raise ProtocolError(
            "malformed", f"CRC must be 4 uppercase hex digits, got {crc_text!r}", seq_guess
        )
    if int(crc_text, 16) != crc16(body):
        raise ProtocolError(
            "crc", f"CRC {crc_text.decode()} does not match {crc16(body):04X}", seq_guess
        )
    try:
        parts = body.decode("ascii").split(",")
    except UnicodeDecodeError:
        raise ProtocolError("malformed", "non-ASCII bytes in body", seq_guess) from None
    kind = parts[0]
    if kind not in HOST_KINDS + REPLY_KINDS:
        raise ProtocolError("malformed", f"unknown frame kind {kind!r}", seq_guess)
    if seq_guess is None:
        raise ProtocolError(
            "malformed", f"sequence number must be an integer 0…65535, got {parts[1:2]}"
        )
    return Frame(kind, tuple(parts[1:]))


def frame_seq(frame: Frame) -> int:
    """The sequence number of a parsed frame (always present after ``parse_frame``)."""
    return int(frame.fields[0])


def seq_is_newer(seq: int, last: int) -> bool:
    """Serial-number comparison modulo 65536: ``seq`` is newer than ``last`` when it is
    1…32767 steps ahead (so 0 is newer than 65535)."""
    return 0 < (seq - last) % SEQ_MODULO < SEQ_MODULO // 2


def next_seq(seq: int) -> int:
    """The sequence number after ``seq`` (wraps 65535 → 0)."""
    return (seq + 1) % SEQ_MODULO


# ---- host → controller -------------------------------------------------------------------


def fraction_to_command(fraction: float, index: int = 0) -> int:
    """Fraction of full thrust (−1…1) → integer per-mille command; ValueError names the index."""
    if not math.isfinite(fraction) or not -1.0 <= fraction <= 1.0:
        raise ValueError(
            f"thruster {index}: command must be a finite fraction in -1…1, got {fraction!r}"
        )
    return round(fraction * 1000)


def thr_frame(seq: int, commands: list[int] | tuple[int, ...]) -> bytes:
    """``$THR,<seq>,<c1>,…,<cn>*CRC\\r\\n`` with per-mille integer commands."""
    for i, c in enumerate(commands):
        if not isinstance(c, int) or not COMMAND_MIN <= c <= COMMAND_MAX:
            raise ValueError(
                f"thruster {i}: command must be an integer in "
                f"{COMMAND_MIN}…{COMMAND_MAX}, got {c!r}"
            )
    return encode_frame(",".join(["THR", str(seq), *(str(c) for c in commands)]))


def arm_frame(seq: int) -> bytes:
    return encode_frame(f"ARM,{seq}")


def disarm_frame(seq: int) -> bytes:
    return encode_frame(f"DISARM,{seq}")


def qry_frame(seq: int) -> bytes:
    return encode_frame(f"QRY,{seq}")


# ---- controller → host -------------------------------------------------------------------


def ack_frame(seq: int, state: str) -> bytes:
    return encode_frame(f"ACK,{seq},{state}")


def nak_frame(seq: int | None, reason: str) -> bytes:
    """A NAK; an unreadable sequence number is sent as ``-``."""
    return encode_frame(f"NAK,{'-' if seq is None else seq},{reason}")


def sta_frame(seq: int, state: str, telemetry: list[tuple[float, float]]) -> bytes:
    """``$STA,<seq>,<state>,<rpm1>,…,<rpmn>,<amp1>,…,<ampn>``: RPM as signed integers,
    current in A with two decimals."""
    rpms = [str(round(rpm)) for rpm, _ in telemetry]
    amps = [f"{amp:.2f}" for _, amp in telemetry]
    return encode_frame(",".join(["STA", str(seq), state, *rpms, *amps]))


def parse_reply(line: bytes) -> Reply:
    """Parse a controller line into a Reply; ProtocolError (reason ``crc``/``malformed``)
    when it is not a well-formed ACK, NAK or STA."""
    try:
        frame = parse_frame(line)
        seq: int | None = frame_seq(frame)
    except ProtocolError as err:
        # A NAK for an unreadable frame carries "-" as its sequence number.
        if err.reason != "malformed" or b"$NAK,-," not in line:
            raise
        frame = _parse_nak_without_seq(line)
        seq = None
    f = frame.fields
    if frame.kind == "ACK" and len(f) == 2 and f[1] in STATES:
        return Reply("ACK", seq, state=f[1])
    if frame.kind == "NAK" and len(f) == 2 and f[1] in NAK_REASONS:
        return Reply("NAK", seq, reason=f[1])
    if frame.kind == "STA" and len(f) >= 4 and len(f) % 2 == 0 and f[1] in STATES:
        n = (len(f) - 2) // 2
        try:
            rpm = tuple(float(x) for x in f[2 : 2 + n])
            amps = tuple(float(x) for x in f[2 + n :])
        except ValueError:
            raise ProtocolError("malformed", f"non-numeric telemetry in {line!r}", seq) from None
        return Reply("STA", seq, state=f[1], rpm=rpm, current_a=amps)
    raise ProtocolError("malformed", f"not a valid reply: {line!r}", seq)


def _parse_nak_without_seq(line: bytes) -> Frame:
    text = line.rstrip(b"\r\n")
    body, _, crc_text = text[text.rfind(b"$") + 1 :].partition(b"*")
    if crc_text != f"{crc16(body):04X}".encode():
        raise ProtocolError("crc", f"CRC mismatch in {line!r}")
    parts = body.decode("ascii").split(",")
    return Frame(parts[0], tuple(parts[1:]))
