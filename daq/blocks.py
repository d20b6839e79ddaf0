"""Read planning: group the register map into as few Modbus requests as possible.

Channels of one register kind whose addresses are strictly contiguous share one
request. Gaps are never bridged (an address the rig file does not name may not
exist on the PLC and would turn the whole request into an exception response).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from daq.config import Channel, RegisterKind

#: Largest count one Modbus request may ask for (Modbus application protocol v1.1b3).
MAX_REGISTERS_PER_READ = 125
MAX_BITS_PER_READ = 2000

#: Order in which kinds are read within one poll (inputs first: they carry the encoder).
KIND_ORDER: tuple[RegisterKind, ...] = ("input", "holding", "discrete", "coil")


@dataclass(frozen=True, slots=True)
class ReadBlock:
    """One read request: ``count`` registers (or bits) of ``kind`` from ``start``."""

    kind: RegisterKind
    start: int
    count: int
    channels: tuple[Channel, ...]

    @property
    def end(self) -> int:
        """Last address covered (inclusive)."""
        return self.start + self.count - 1

    def describe(self) -> str:
        """Human-readable span, e.g. ``input registers 0-9 (tow_position, ...)``."""
        noun = {
            "input": "input registers",
            "holding": "holding registers",
            "coil": "coils",
            "discrete": "discrete inputs",
        }[self.kind]
        names = ", ".join(c.name for c in self.channels)
        return f"{noun} {self.start}-{self.end} ({names})"


def plan_blocks(channels: Iterable[Channel]) -> list[ReadBlock]:
    """Group channels into contiguous read blocks, one list per kind in ``KIND_ORDER``."""
    by_kind: dict[str, list[Channel]] = {}
    for ch in channels:
        by_kind.setdefault(ch.kind, []).append(ch)
    blocks: list[ReadBlock] = []
    for kind in KIND_ORDER:
        members = sorted(by_kind.get(kind, []), key=lambda c: c.address)
        limit = MAX_BITS_PER_READ if kind in ("coil", "discrete") else MAX_REGISTERS_PER_READ
        current: list[Channel] = []
        for ch in members:
            if current:
                start = current[0].address
                next_free = current[-1].address + current[-1].width
                if ch.address != next_free or ch.address + ch.width - start > limit:
                    blocks.append(_block(kind, current))
                    current = []
            current.append(ch)
        if current:
            blocks.append(_block(kind, current))
    return blocks


def _block(kind: RegisterKind, members: list[Channel]) -> ReadBlock:
    start = members[0].address
    count = members[-1].address + members[-1].width - start
    return ReadBlock(kind=kind, start=start, count=count, channels=tuple(members))
