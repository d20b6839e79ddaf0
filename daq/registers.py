"""Register codec: SI value <-> 16-bit Modbus words, as the rig file describes.

Used by both ends of the wire (the simulated PLC encodes, the driver decodes), so
scale, data type and 32-bit word order are written once.
"""

from __future__ import annotations

import math
import struct

from daq.config import Channel

_STRUCT = {"uint16": "H", "int16": "h", "uint32": "I", "int32": "i", "float32": "f"}
#: The value's big-endian bytes, and the same bytes as 16-bit words (precompiled: a poll
#: encodes and decodes every channel).
_VALUE = {name: struct.Struct(">" + fmt) for name, fmt in _STRUCT.items()}
_WORDS = {size: struct.Struct(">" + "H" * (size // 2)) for size in (2, 4)}
_RANGE = {
    "uint16": (0, 0xFFFF),
    "int16": (-0x8000, 0x7FFF),
    "uint32": (0, 0xFFFFFFFF),
    "int32": (-0x80000000, 0x7FFFFFFF),
}


def raw_to_words(channel: Channel, raw: int | float) -> list[int]:
    """Pack a raw (unscaled) value into the channel's register words."""
    if channel.type != "float32":
        lo, hi = _RANGE[channel.type]
        raw = int(raw)
        # A wrapping counter wraps; any other value saturates at the type's range.
        raw = (raw - lo) % (hi - lo + 1) + lo if channel.wraps else min(max(raw, lo), hi)
    value = _VALUE[channel.type]
    words = list(_WORDS[value.size].unpack(value.pack(raw)))
    if channel.word_order == "little":
        words.reverse()
    return words


def words_to_raw(channel: Channel, words: list[int]) -> int | float:
    """Unpack the channel's register words into its raw value."""
    if len(words) != channel.width:
        raise ValueError(f"channel {channel.name!r} needs {channel.width} words, got {len(words)}")
    ordered = reversed(words) if channel.word_order == "little" else words
    value = _VALUE[channel.type]
    return value.unpack(_WORDS[value.size].pack(*ordered))[0]


def si_to_raw(channel: Channel, value: float) -> int | float:
    """SI value -> raw register value (rounded to the nearest count for integers)."""
    raw = (value - channel.offset) / channel.scale
    if channel.type == "float32":
        return raw
    if not math.isfinite(raw):
        raise ValueError(f"channel {channel.name!r}: cannot encode {value!r}")
    return round(raw)


def raw_to_si(channel: Channel, raw: int | float) -> float:
    """Raw register value -> SI value."""
    return raw * channel.scale + channel.offset


def encode(channel: Channel, value: float) -> list[int]:
    """SI value -> register words."""
    return raw_to_words(channel, si_to_raw(channel, value))


def decode(channel: Channel, words: list[int]) -> float:
    """Register words -> SI value (no unwrapping; see ``daq.unwrap``)."""
    return raw_to_si(channel, words_to_raw(channel, words))


def wrap_period(channel: Channel) -> int:
    """Number of raw counts after which a wrapping counter repeats."""
    lo, hi = _RANGE[channel.type]
    return hi - lo + 1
