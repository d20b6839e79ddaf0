"""The rig's safe state: brakes engaged (release coils cleared) and thrusters at zero, and
what putting the rig in it did, as every run's ending records it."""

from __future__ import annotations

from dataclasses import dataclass

#: Brakes the safe state engages (those the rig file lists).
RELEASE_CHANNELS = ("tow_release", "spin_release")


@dataclass(frozen=True)
class SafeState:
    """What putting the rig in its safe state did: the release coils cleared (brakes
    engaged), whether the thrusters were confirmed at zero, and what failed."""

    brakes_engaged: tuple[str, ...]
    thrusters_zero: bool | None  # None: the rig has no thrusters
    errors: tuple[str, ...] = ()

    def describe(self) -> str:
        """``safe state: brake engaged (tow_release cleared); thrusters at zero``."""
        parts = []
        if self.brakes_engaged:
            parts.append(f"brake engaged ({', '.join(self.brakes_engaged)} cleared)")
        if self.thrusters_zero is not None:
            parts.append(
                "thrusters at zero" if self.thrusters_zero else "thrusters NOT confirmed at zero"
            )
        text = "safe state: " + ("; ".join(parts) or "nothing to engage")
        return text + (f"; failed: {'; '.join(self.errors)}" if self.errors else "")
