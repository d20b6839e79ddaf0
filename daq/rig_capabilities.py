"""What a rig can do, from what its rig file lists.

A rig file lists only the channels (and sections) its rig has. Each run kind says what it
needs (``KindSpec.needs`` in ``daq.procedures.run_kinds``, a ``Needs``); this module checks a
need against a rig and words what is missing ("spin: needs channel spin_release"). The
safety channels are not needed by any kind: they are used when present, and ``safety``
says what the rig does without each one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from daq.config import RigConfig


@dataclass(frozen=True)
class Needs:
    """What a run kind (or one of its drives) needs from the rig file."""

    #: Channels the procedure reads or writes (``[[channels]]`` names).
    channels: tuple[str, ...] = ()
    #: A ``[thrusters]`` section (the thruster controller).
    thrusters: bool = False
    #: A ``[pendulum]`` section (the pendulum's geometry).
    pendulum: bool = False
    #: Optional rig-file settings that must be given, as ``section.field``.
    settings: tuple[str, ...] = ()

    def __add__(self, other: Needs) -> Needs:
        return Needs(
            channels=self.channels + tuple(c for c in other.channels if c not in self.channels),
            thrusters=self.thrusters or other.thrusters,
            pendulum=self.pendulum or other.pendulum,
            settings=self.settings + tuple(s for s in other.settings if s not in self.settings),
        )

    def missing(self, rig: RigConfig) -> list[str]:
        """What ``rig`` lacks, in words: ``["channel spin_release", "a [thrusters] section"]``."""
        out = [f"channel {name}" for name in self.channels if not rig.has(name)]
        if self.thrusters and rig.thrusters is None:
            out.append("a [thrusters] section")
        if self.pendulum and rig.pendulum is None:
            out.append("a [pendulum] section")
        for path in self.settings:
            section, name = path.split(".", 1)
            if getattr(getattr(rig, section), name) is None:
                out.append(path)
        return out


@dataclass(frozen=True)
class Capability:
    """Whether the rig can do something; ``reason`` says why not (``None`` when it can)."""

    available: bool
    reason: str | None = None

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"available": self.available}
        if self.reason is not None:
            out["reason"] = self.reason
        return out


def capability(what: str, needs: Needs, rig: RigConfig) -> Capability:
    """``what`` (``"spin"``) on ``rig``: available, or the reason naming what is missing."""
    missing = needs.missing(rig)
    if not missing:
        return Capability(True)
    return Capability(False, f"{what}: needs {', '.join(missing)}")


#: Channels that make runs safer or better and are used when present; what happens without.
SAFETY_CHANNELS: dict[str, str] = {
    "end_of_travel": "no end-of-travel switch: a tow stops when the encoder has travelled "
    "max_distance_m (at most geometry.end_of_travel_m)",
    "estop": "no emergency-stop input: runs are not checked against a hardware e-stop",
    "heartbeat": "no PLC heartbeat: a frozen PLC is noticed only when its reads fail",
    "supply_voltage": "no supply-voltage channel: thrust is not corrected for the supply "
    "voltage (calibrations and thruster runs record none)",
}


def safety(rig: RigConfig) -> dict[str, Capability]:
    """Each safety channel: used (available) or what the rig does without it."""
    return {
        name: Capability(True) if rig.has(name) else Capability(False, without)
        for name, without in SAFETY_CHANNELS.items()
    }
