"""What each procedure asks for, declared once as a pydantic model: the HTTP request
body (its OpenAPI schema), the ``rig`` command's options (``api.cli.options`` derives
them from the fields) and the keys a sequence step may hold.

A field's description is both the API's description and the CLI's help; its
:class:`Flag` says how the command line spells it. Limits that depend on the rig file
(``max_force_n``, end of travel, …) are checked by the models' own validators when the rig
is in the validation context: ``TowRequest.checked(raw, rig)`` is
``model_validate(raw, context={"rig": rig})`` and returns the request, frozen, with the
rig's defaults filled in: it *is* the procedure's parameters. Without a rig (the HTTP body)
only the types are checked. Every face gives the same ``ParameterError`` naming the field
and the allowed range (``daq.procedures.params``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Annotated, Any, ClassVar

from pydantic import (
    Field,
    ValidationInfo,
    field_validator,
    model_validator,
)

from daq.procedures import params as p
from daq.procedures.calibration_request import (
    MAX_CALIBRATION_COMMANDS,
    THRUST_SWEEP_DEFAULT,
    CalibrationRequest,
    calibration_parameters,
)
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.procedures.procedure_request import (
    Baseline,
    Drive,
    MaxTime,
    ProcedureRequest,
    RequiredByCheck,
    RigLimit,
    RunMetadataIn,
    SignedLoadRequest,
    StrictRequest,
    comma_separated_floats,
    required_by_check,
    rig_of,
)
from daq.vocabulary import RunKind

if TYPE_CHECKING:
    from daq.config import RigConfig

__all__ = [
    "MAX_CALIBRATION_COMMANDS",
    "THRUST_SWEEP_DEFAULT",
    "CalibrationRequest",
    "Flag",
    "ManualThrustRequest",
    "PendulumRequest",
    "ProcedureRequest",
    "RunMetadataIn",
    "SpinRequest",
    "StrictRequest",
    "TowRequest",
    "calibration_parameters",
    "comma_separated_floats",
    "manual_thrust_parameters",
    "pendulum_parameters",
    "spin_parameters",
    "tow_parameters",
]


class TowRequest(SignedLoadRequest):
    """A tow test: ``force_n`` or ``weight_kg`` (force = weight × the rig's g); ``drive``
    weight|thrusters (thrusters: ``force_n`` through the calibrated inverse map). A negative
    load is a reverse tow: from the far end back toward the start (far-end pulley)."""

    force_n: Annotated[
        float | None,
        Field(
            title="Force (N)",
            description="Towing force in N, 0 < |F| ≤ the rig's max_force_n; negative: a "
            "reverse tow from the far end (far-end pulley, or thrusters turned round).",
        ),
        Flag("--force"),
        RigLimit.of_setting("limits.max_force_n", signed=True),
    ] = None
    weight_kg: Annotated[
        float | None,
        Field(
            title="or hung weight (kg)",
            description="Hung weight in kg (force = weight × the rig's g); negative: hung on "
            "the far-end pulley (a reverse tow).",
        ),
        Flag("--weight"),
        RigLimit(lambda rig: rig.limits.max_force_n / rig.rig.g, signed=True),
    ] = None
    drive: Annotated[
        Drive,
        Field(
            title="Drive",
            description="weight: a hung weight pulls; thrusters: the calibrated thrusters.",
        ),
        Flag(
            "--thrusters", "thrusters", "Drive the force with the calibrated thrusters (no weight)."
        ),
    ] = "weight"
    max_distance_m: Annotated[
        float | None,
        Field(
            title="Max distance (m)",
            description="Stop after this many metres (default: end of travel; a reverse tow: "
            "its room back to the start).",
        ),
        Flag("--max-distance"),
        RigLimit(lambda rig: rig.geometry.end_of_travel_m),
    ] = None
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0

    kind: ClassVar[RunKind] = RunKind.TOW
    load_field: ClassVar[str] = "force_n"
    load_unit: ClassVar[str] = "N"

    @classmethod
    def _lever(cls, rig: RigConfig) -> tuple[float, float, str]:
        limit, g = float(cls.drive_limit(rig) or math.nan), rig.rig.g
        return 1.0, limit, f", max_force_n / g = {limit:g} N / {g:g}"

    @field_validator("max_distance_m")
    @classmethod
    def _distance(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None:
            return value
        load = info.data.get("force_n")
        load = info.data.get("weight_kg") if load is None else load
        if load is not None and load < 0:  # from the far end back toward the start
            room = rig.geometry.reverse_travel
            why = f", a reverse tow's room from {rig.geometry.reverse_start:g} m back to the start"
        else:
            room, why = rig.geometry.end_of_travel_m, ", end_of_travel_m"
        return p.in_range(
            "max_distance_m", value, low=0, high=room, unit="m", default=room, why_high=why
        )


class SpinRequest(SignedLoadRequest):
    """A spin test: ``torque_nm`` or ``weight_kg`` on the drum; ``drive`` weight|thrusters.
    A negative load is a reverse spin (the cord wound the other way round the drum)."""

    torque_nm: Annotated[
        float | None,
        Field(
            title="Torque (N·m)",
            description="Torque in N·m, 0 < |τ| ≤ the rig's max_torque_nm; negative: a reverse "
            "spin (cord wound the other way, or thrusters turned round).",
        ),
        Flag("--torque"),
        RigLimit.of_setting("limits.max_torque_nm", signed=True),
    ] = None
    weight_kg: Annotated[
        float | None,
        Field(
            title="or weight on drum (kg)",
            description="Weight on the drum in kg (τ = weight × g × drum radius); negative: "
            "the cord wound the other way (a reverse spin).",
        ),
        Flag("--weight"),
    ] = None
    drive: Annotated[
        Drive,
        Field(
            title="Drive",
            description="weight: a weight on the drum turns; thrusters: the thrusters.",
        ),
        Flag("--thrusters", "thrusters", "Drive the torque with the calibrated thrusters."),
    ] = "weight"
    max_angle_rad: Annotated[
        float | None,
        Field(
            title="Max angle (rad)",
            description="Stop after this angle, rad (default: cord length).",
        ),
        Flag("--max-angle"),
    ] = None
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0

    kind: ClassVar[RunKind] = RunKind.SPIN
    load_field: ClassVar[str] = "torque_nm"
    load_unit: ClassVar[str] = "N·m"

    @classmethod
    def _lever(cls, rig: RigConfig) -> tuple[float, float, str]:
        # A rig without a drum radius or torque limit cannot spin (``KindSpec.check``
        # refuses first, naming what is missing); nan keeps a direct call from crashing.
        radius = rig.geometry.spin_drum_radius_m or math.nan
        return radius, cls.drive_limit(rig) or math.nan, ", max_torque_nm / (g · drum radius)"

    @field_validator("max_angle_rad")
    @classmethod
    def _angle(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None:
            return value
        most = rig.geometry.spin_max_angle_rad
        return p.in_range(
            "max_angle_rad", value, low=0, high=most, unit="rad", default=most,
            why_high=", spin_max_angle_rad",
        )  # fmt: skip


class PendulumRequest(ProcedureRequest):
    """A pendulum free-decay test (needs a rig file with a ``[pendulum]`` section)."""

    start_angle_rad: Annotated[
        float | None,
        Field(
            title="Start angle (rad)",
            description="Start angle, rad (0 < φ₀ ≤ the rig file's pendulum max_angle_rad); "
            "required.",
        ),
        Flag("--angle"),
        RequiredByCheck(),
    ] = None
    stop_amplitude_rad: Annotated[
        float,
        Field(
            title="Stop below amplitude (rad)",
            description="Stop once the amplitude over the last full cycle is below this, rad.",
        ),
        Flag("--stop-amplitude"),
    ] = 0.005
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0

    kind: ClassVar[RunKind] = RunKind.PENDULUM

    @model_validator(mode="before")
    @classmethod
    def _has_pendulum(cls, data: Any, info: ValidationInfo) -> Any:
        rig = rig_of(info)
        if rig is not None and rig.pendulum is None:
            why = "a rig file with a [pendulum] section (see docs/pendulum.md)"
            raise ParameterError([("rig", rig.rig.name, why)])
        return data

    @field_validator("start_angle_rad")
    @classmethod
    def _start(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None or rig.pendulum is None:
            return value
        return p.in_range(
            "start_angle_rad", value, low=0, high=rig.pendulum.max_angle_rad, unit="rad",
            required=required_by_check(cls, "start_angle_rad"),
            why_high=", the rig's pendulum max_angle_rad",
        )  # fmt: skip

    @field_validator("stop_amplitude_rad")
    @classmethod
    def _stop(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None or rig.pendulum is None:
            return value
        start = info.data.get("start_angle_rad")
        high = start if start is not None else rig.pendulum.max_angle_rad
        stop = p.in_range(
            "stop_amplitude_rad", value, low=0, high=high, unit="rad", why_high=", start_angle_rad"
        )
        if stop is not None and start is not None and stop >= start:
            why = f"allowed below start_angle_rad ({start:g} rad)"
            raise ParameterError([("stop_amplitude_rad", stop, why)])
        return stop

    @field_validator("max_time_s")
    @classmethod
    def _max_time(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        return value if rig is None else p.max_time(value, rig, ", rig limit max_run_s")


#: Longest a manual thrust run may hold its command, s (the rig's ``max_run_s`` if shorter).
MAX_MANUAL_THRUST_S = 60.0


def _thruster_count(rig: RigConfig) -> int:
    return rig.thrusters.count if rig.thrusters is not None else 0


def _manual_seconds(rig: RigConfig) -> float:
    return min(MAX_MANUAL_THRUST_S, rig.limits.max_run_s)


class ManualThrustRequest(ProcedureRequest):
    """One thruster held at a command for a bounded time on the thrust stand, by hand: a
    dead-man, back to zero when the time ends (or on abort, emergency stop, a link fault)."""

    thruster: Annotated[
        int,
        Field(
            title="Thruster",
            description="Which thruster, 1 … the rig's thrusters.count (as in thruster1_rpm).",
        ),
        Flag("--thruster"),
        RigLimit(lambda rig: _thruster_count(rig) or None),
    ] = 1
    command: Annotated[
        float | None,
        Field(
            title="Command (fraction)",
            description="Command as a fraction of full thrust, |c| ≤ the rig's "
            "max_thruster_command; negative: reverse thrust. Required.",
        ),
        Flag("--command", metavar="C"),
        RigLimit.of_setting("limits.max_thruster_command", signed=True),
        RequiredByCheck(),
    ] = None
    duration_s: Annotated[
        float,
        Field(
            title="Duration (s)",
            description=f"How long the command is held, s (at most {MAX_MANUAL_THRUST_S:g} s, "
            "or the rig's max_run_s); then the thruster goes back to zero.",
        ),
        Flag("--duration"),
        RigLimit(_manual_seconds),
    ] = 5.0

    kind: ClassVar[RunKind] = RunKind.MANUAL_THRUST

    @field_validator("thruster")
    @classmethod
    def _thruster(cls, value: int, info: ValidationInfo) -> int:
        rig = rig_of(info)
        if rig is None:
            return value
        count = _thruster_count(rig)
        if not 1 <= value <= count:
            why = f"allowed 1 ≤ thruster ≤ {count} (the rig's thrusters.count)"
            raise ParameterError([("thruster", value, why)])
        return value

    @field_validator("command")
    @classmethod
    def _command(cls, value: float | None, info: ValidationInfo) -> float | None:
        rig = rig_of(info)
        if rig is None:
            return value
        most = cls.rig_limit("command", rig) or math.nan
        return p.in_range(
            "command", value, low=-most, high=most, unit="(fraction of full thrust)",
            low_inclusive=True, required=required_by_check(cls, "command"),
            why_high=cls.limit_named("command"),
        )  # fmt: skip

    @field_validator("duration_s")
    @classmethod
    def _duration(cls, value: float, info: ValidationInfo) -> float:
        rig = rig_of(info)
        if rig is None:
            return value
        most = _manual_seconds(rig)
        why = f", at most {MAX_MANUAL_THRUST_S:g} s or the rig's max_run_s"
        return p.in_range("duration_s", value, low=0, high=most, unit="s", why_high=why)

    def commands(self, count: int) -> list[float]:
        """Per thruster (``count`` of them): ``command`` for the chosen one, 0 elsewhere."""
        chosen = float(self.command or 0.0)
        return [chosen if i == self.thruster else 0.0 for i in range(1, count + 1)]


#: A request (the fields given) checked against the rig → the procedure's parameters.
tow_parameters = TowRequest.checked
spin_parameters = SpinRequest.checked
pendulum_parameters = PendulumRequest.checked
manual_thrust_parameters = ManualThrustRequest.checked
