"""The thrusters' own configuration types: the ``[thrusters]`` section of a rig file, and
the command limits the driver enforces (``[limits]`` of the rig file satisfies them)."""

from __future__ import annotations

from typing import Annotated, Protocol

from pydantic import BaseModel, ConfigDict, Field

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]

#: Longest interval the slew limit credits between two steps (s). A command after a
#: long pause still ramps instead of jumping. The driver enforces it; the loader models
#: the ramp of runs recorded before the confirmed outputs were stored with it.
MAX_SLEW_INTERVAL_S = 0.1


class CommandLimits(Protocol):
    """What the driver clamps to: the largest command (fraction of full scale) and the
    largest change of command per second."""

    @property
    def max_thruster_command(self) -> float: ...

    @property
    def max_command_slew_per_s(self) -> float: ...


class ThrusterPort(BaseModel):
    """The rig file's ``[thrusters]`` section: where the controller is, what the thrusters are."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    #: Device path, pyserial URL (``socket://127.0.0.1:7000``), or ``"sim"`` to use
    #: the simulated controller's pty.
    port: str = "sim"
    baudrate: Annotated[int, Field(ge=1200, le=921600)] = 115200
    count: Annotated[int, Field(ge=1, le=16)] = 2
    #: Full-scale (command 1000 ‰) forward thrust of one thruster, N.
    full_scale_thrust_n: PositiveFloat = 40.0
    #: Lever arm of the thrusters about the vertical axis, m (for thruster-driven yaw).
    yaw_lever_arm_m: PositiveFloat = 0.2
    #: Thrust response time (first-order time constant, s, from the thrusters' datasheet):
    #: the drive of thruster-driven runs is rebuilt with it (0 = thrust follows at once).
    time_constant_s: Annotated[float, Field(ge=0, le=5)] = 0.0
    #: Thrust at a fixed command scales as (supply voltage)^voltage_exponent (datasheet;
    #: ≈ 1.5 for brushless thrusters): the drive of thruster-driven runs is corrected by
    #: the supply voltage recorded during the run against the calibration's (0 = not).
    voltage_exponent: Annotated[float, Field(ge=0, le=3)] = 0.0
    ack_timeout_s: Annotated[float, Field(gt=0, le=2)] = 0.1
    #: Safety cut-off, A: a thruster drawing more current than this (the controller's
    #: telemetry, read every ``current_check_s`` while armed) stops the test, thrusters at
    #: zero (None: no cut-off).
    max_current_a: Annotated[float, Field(gt=0, le=500)] | None = None
    current_check_s: Annotated[float, Field(ge=0.05, le=5)] = 0.25

    def thrust_layout(self, kind: str) -> tuple[list[float], float]:
        """Per-thruster sign and arm (m; 1 for a force) that turn thruster forces into the
        drive of a ``"tow"`` (Σ F) or a ``"spin"`` (Σ sign·F·L)."""
        if kind == "tow":
            return [1.0] * self.count, 1.0
        if kind == "spin":
            return self.yaw_signs(), self.yaw_lever_arm_m
        raise ValueError(f"kind: {kind!r} is not allowed; allowed 'tow' or 'spin'")

    def yaw_signs(self) -> list[float]:
        """+1 for thrusters that turn the vehicle positive about the vertical axis (even
        index, port side), −1 for the others; each acts at ``yaw_lever_arm_m``."""
        return [1.0 if i % 2 == 0 else -1.0 for i in range(self.count)]
