"""The words runs are stored and shown with, defined once: run kinds, run statuses and
the axis each kind moves (its position channel, release coil, end switch, weight act, drive
and drive train).

``StrEnum`` members are the strings themselves, so the database, the JSON bodies and the
CLI keep ``"tow"`` and ``"completed"``. Light on purpose (no pydantic, no numpy): ``rig
runs`` and the store import it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum


class RunKind(StrEnum):
    """What a run recorded (a run's ``kind``)."""

    TOW = "tow"
    SPIN = "spin"
    PENDULUM = "pendulum"
    THRUST_CALIBRATION = "thrust_calibration"
    #: One thruster held at a command for a bounded time on the thrust stand (by hand).
    MANUAL_THRUST = "manual_thrust"
    #: A free decay of one degree of freedom, imported (its ``dof`` parameter says which).
    DECAY = "decay"


class RunStatus(StrEnum):
    """How a run stands: ``running`` until it ends one of the other three ways."""

    RUNNING = "running"
    COMPLETED = "completed"
    ABORTED = "aborted"
    #: The process died under a running run; found and marked on the next start.
    INTERRUPTED = "interrupted"


#: Statuses a run never leaves (its metadata no longer changes).
ENDED_STATUSES = (RunStatus.COMPLETED, RunStatus.ABORTED, RunStatus.INTERRUPTED)


class Axis(StrEnum):
    """The degree of freedom a run moves."""

    SURGE = "surge"
    YAW = "yaw"
    #: The pendulum's swing (roll or pitch, as the rig file's ``[pendulum]`` says).
    SWING = "swing"
    #: A free decay's degree of freedom, named by its run's ``dof`` parameter.
    DOF = "dof"


@dataclass(frozen=True)
class DriveTrain:
    """What turns with a weight-driven axis, named by the rig file's ``[geometry]`` keys: its
    inertia J (kg·m²) and radius r (m). ``linear``: seen along a linear axis as J/r² (kg: a
    tow's pulley), else as J about the axis, r then being the lever of a hung weight (m·r²:
    a spin's drum). ``turns_with_thrusters``: still coupled when the thrusters drive (a
    tow's line is unhooked and its pulley stands still: False)."""

    inertia_key: str
    radius_key: str
    linear: bool
    turns_with_thrusters: bool


@dataclass(frozen=True)
class AxisTerms:
    """Everything named after the axis a kind moves.

    ``drive_key``/``drive_unit`` are the applied load a weight or the thrusters give
    (``None`` for a free decay, which has no drive)."""

    axis: Axis
    position_channel: str  # e.g. "tow_position"
    unit: str  # of the position: "m" or "rad"
    release_coil: str  # the PLC coil whose rising edge lets the run go
    weight_act: str  # the operator act that loads the axis
    drive_key: str | None = None  # the run parameter holding the drive, e.g. "force_n"
    drive_unit: str | None = None
    travel_key: str | None = None  # the parameter limiting the motion, e.g. "max_distance_m"
    end_switch: str | None = None  # the channel a run ends on at the end of travel, if any
    drive_train: DriveTrain | None = None  # what turns with the drive (its inertia adds)
    rate: str | None = None  # the position's rate the live plot derives, e.g. "speed"
    #: The longest hole without a good sample a run of this axis tolerates, s (a longer
    #: one aborts it: ``daq.sample_losses``); None: any (nothing is fitted to the motion).
    loss_tolerance_s: float | None = None

    @property
    def inertia_is_mass(self) -> bool:
        """The axis translates (surge): its inertia is a mass (kg), which a body's own
        declared mass (``dry_mass_kg``) bounds from below; a rotation's is in kg·m²."""
        return self.axis is Axis.SURGE

    @property
    def rate_label(self) -> str | None:
        """How the live plot names the rate: ``"speed (from position)"``."""
        source = self.position_channel.rsplit("_", 1)[-1]
        return None if self.rate is None else f"{self.rate.replace('_', ' ')} (from {source})"


#: kind → axis → position channel → drive key: the one table of axis words.
AXES: dict[str, AxisTerms] = {  # keyed by RunKind (a str), looked up by stored strings
    RunKind.TOW: AxisTerms(
        Axis.SURGE,
        "tow_position",
        "m",
        "tow_release",
        "hang_tow_weight",
        "force_n",
        "N",
        "max_distance_m",
        end_switch="end_of_travel",
        drive_train=DriveTrain("pulley_inertia_kg_m2", "pulley_radius_m", True, False),
        rate="speed",
        # 2/3 of the shortest time constant M/(dF/dv) of BENBAM's tows (~0.73 s at 44 N):
        # a longer hole can hide most of the acceleration that fixes the inertia.
        loss_tolerance_s=0.5,
    ),
    RunKind.SPIN: AxisTerms(
        Axis.YAW,
        "yaw_angle",
        "rad",
        "spin_release",
        "hang_spin_weight",
        "torque_nm",
        "N·m",
        "max_angle_rad",
        drive_train=DriveTrain("spin_drum_inertia_kg_m2", "spin_drum_radius_m", False, True),
        rate="yaw_rate",
        # a spin's time constant I/(dQ/dω) is longer (~2 s at 1 N·m): 0.5 s stays well inside
        loss_tolerance_s=0.5,
    ),
    RunKind.PENDULUM: AxisTerms(
        Axis.SWING,
        "pendulum_angle",
        "rad",
        "pendulum_release",
        "pull_pendulum",
        # its turning points fix the amplitude's decay: a hole over 2 samples can hide one
        loss_tolerance_s=0.25,
    ),
    RunKind.DECAY: AxisTerms(Axis.DOF, "decay_position", "m or rad", "decay_release", "offset"),
}

#: The kinds driven by a constant load (weight or thrusters): tow and spin.
DRIVEN_KINDS = tuple(kind for kind, terms in AXES.items() if terms.drive_key is not None)
#: Per driven kind: the channel that records its position, and the parameter holding its
#: drive with the drive's unit (``"force_n"``, ``"N"``).
POSITION_CHANNEL: dict[str, str] = {kind: AXES[kind].position_channel for kind in DRIVEN_KINDS}
DRIVE_FIELD: dict[str, tuple[str, str]] = {
    kind: (str(AXES[kind].drive_key), str(AXES[kind].drive_unit)) for kind in DRIVEN_KINDS
}
#: What moves the vehicle in every run of a kind that has one drive only (the store's
#: ``runs.drive``): a thrust calibration and a manual thrust run drive the thrusters. Other
#: kinds name theirs in their ``drive`` parameter (a hung weight when a mass is given, else
#: none: a pendulum).
FIXED_DRIVE: dict[str, str] = {
    RunKind.THRUST_CALIBRATION: "thrusters",
    RunKind.MANUAL_THRUST: "thrusters",
}
#: Per driven kind: the channel an imported run's logged drive (one value per sample, in
#: the drive's SI unit) is stored as; the run's ``drive_channel`` parameter names it.
LOGGED_DRIVE_CHANNEL: dict[str, str] = {RunKind.TOW: "drive_force", RunKind.SPIN: "drive_torque"}


def driven_axis(kind: str) -> AxisTerms:
    """The axis of a weight- or thruster-driven kind; ``ValueError`` naming the allowed."""
    terms = AXES.get(kind)  # type: ignore[call-overload]  # a StrEnum key matches its str
    if terms is None or terms.drive_key is None:
        allowed = " or ".join(repr(str(k)) for k in DRIVEN_KINDS)
        raise ValueError(f"kind: {kind!r} is not allowed; allowed {allowed}")
    return terms


def quoted_kinds(kinds: tuple[str, ...] | None = None) -> str:
    """``'tow', 'spin', 'pendulum' or 'thrust_calibration'`` for error messages."""
    names = [repr(str(k)) for k in (kinds if kinds is not None else tuple(RunKind))]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " or " + names[-1]


#: The thrusters' telemetry channels a thruster-driven run logs per thruster (1-based
#: ``thruster1_rpm``, ``thruster1_current``) and their units (UDUNITS text).
THRUSTER_TELEMETRY_UNITS: dict[str, str] = {"rpm": "rpm", "current": "A"}


def thruster_telemetry_channels(count: int) -> list[str]:
    """``["thruster1_rpm", …, "thruster1_current", …]`` for ``count`` thrusters."""
    return [
        f"thruster{i}_{quantity}"
        for quantity in THRUSTER_TELEMETRY_UNITS
        for i in range(1, count + 1)
    ]


def thruster_telemetry_unit(channel: str) -> str | None:
    """The unit of a thruster telemetry channel (``"thruster2_current"`` → ``"A"``), else None."""
    prefix, _, quantity = channel.partition("_")
    if prefix.startswith("thruster") and prefix[8:].isdigit():
        return THRUSTER_TELEMETRY_UNITS.get(quantity)
    return None
