"""The thrust calibration's request: a sweep of thruster commands on the load cell, checked
against the rig (``max_thruster_command``) and against what the per-side curve fit needs
(``estimation.thrust.MIN_POINTS_PER_SIDE``), so a sweep that could not be fitted is refused
before the thrusters move. See ``daq.procedures.requests`` for how a request is checked."""

from __future__ import annotations

from typing import Annotated, Any, ClassVar

from pydantic import Field, ValidationInfo, field_validator

from daq.procedures import params as p
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.procedures.procedure_request import ProcedureRequest, comma_separated_floats, rig_of
from daq.vocabulary import RunKind
from estimation.thrust import MIN_POINTS_PER_SIDE

THRUST_SWEEP_DEFAULT = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
#: Most command steps one calibration may sweep (each is held ``settle_s`` plus samples,
#: up and down, both directions): longer sweeps are split into several calibrations.
MAX_CALIBRATION_COMMANDS = 50


_SWEEP = ",".join(f"{c:g}" for c in THRUST_SWEEP_DEFAULT[:2]) + f",...,{THRUST_SWEEP_DEFAULT[-1]:g}"


class CalibrationRequest(ProcedureRequest):
    """A thrust calibration sweep (commands as fractions of full thrust)."""

    commands: Annotated[
        list[float] | None,
        Field(
            title="Commands (fractions, comma separated)",
            max_length=MAX_CALIBRATION_COMMANDS,
            description=f"Command fractions, 0 ≤ c ≤ the rig's max_thruster_command, at most "
            f"{MAX_CALIBRATION_COMMANDS} (default {_SWEEP}); swept up then down, then reversed.",
        ),
        Flag("--commands", metavar="C1,C2,...", parse=comma_separated_floats),
    ] = None
    settle_s: Annotated[
        float, Field(title="Settle (s)", description="Settling time per step, s."), Flag("--settle")
    ] = 1.0
    samples_per_step: Annotated[
        int,
        Field(title="Samples per step", description="Samples averaged per step."),
        Flag("--samples"),
    ] = 10
    tare_samples: Annotated[
        int,
        Field(title="Tare samples", description="Samples averaged for the load cell's zero."),
        Flag("--tare-samples"),
    ] = 20
    reverse: Annotated[
        bool,
        Field(
            title="also reverse thrust",
            description="Also sweep the thrusters in reverse; required, since the curve is "
            "fitted per side (false is refused before the thrusters move).",
        ),
        Flag("--no-reverse", False, "Refused: the curve is fitted per side."),
    ] = True

    kind: ClassVar[RunKind] = RunKind.THRUST_CALIBRATION

    @property
    def sweep(self) -> list[float]:
        """Commands in the order applied: up then down (and the same for reverse)."""
        up = sorted(set(self.commands or ()))
        order = up + up[-2::-1]
        if self.reverse:
            neg = [-c for c in up if c > 0]
            order += neg + neg[-2::-1] + [0.0]
        return order

    def to_json(self) -> dict[str, Any]:
        return super().to_json() | {"commands": list(self.commands or ()), "sweep": self.sweep}

    @field_validator("commands")
    @classmethod
    def _commands(cls, value: list[float] | None, info: ValidationInfo) -> Any:
        rig = rig_of(info)
        if rig is None:
            return value
        cmax = rig.limits.max_thruster_command
        commands = list(THRUST_SWEEP_DEFAULT) if value is None else value
        if not commands:
            raise ParameterError(
                [("commands", commands, f"a non-empty list of fractions 0 ≤ c ≤ {cmax:g}")]
            )
        good: list[float] = []
        problems: list[p.Problem] = []
        for i, command in enumerate(commands):
            try:
                good.append(_command(f"commands[{i}]", command, cmax))
            except ParameterError as err:
                problems += err.problems
        if problems:
            raise ParameterError(problems)
        return sorted(good if 0.0 in good else [*good, 0.0])

    @field_validator("reverse")
    @classmethod
    def _both_sides(cls, value: bool, info: ValidationInfo) -> bool:
        """The curve is fitted per side (``MIN_POINTS_PER_SIDE`` each; a command is visited up
        and down): a sweep too short for it is refused before the thrusters move."""
        if rig_of(info) is None or "commands" not in info.data:
            return value  # no rig to check against, or the commands were refused already
        given = info.data["commands"]
        up = [c for c in (THRUST_SWEEP_DEFAULT if given is None else given) if c > 0]
        if 2 * len(up) - 1 < MIN_POINTS_PER_SIDE:
            need = f"at least {(MIN_POINTS_PER_SIDE + 2) // 2} commands above 0 on each side"
            raise ParameterError([("commands", given, need)])
        if not value:
            raise ParameterError([("reverse", value, "true: the curve needs the reverse side")])
        return value

    @field_validator("settle_s", "samples_per_step", "tare_samples")
    @classmethod
    def _steps(cls, value: float, info: ValidationInfo) -> float:
        if rig_of(info) is None:
            return value
        name = str(info.field_name)
        if name == "settle_s":
            return p.in_range(name, value, low=0, high=30, unit="s", low_inclusive=True)
        return int(p.in_range(name, value, low=1, high=1000, unit="samples", low_inclusive=True))


def _command(name: str, value: float, most: float) -> float:
    """One command of a sweep: a fraction 0 … the rig's ``max_thruster_command``."""
    unit, why = "(fraction of full thrust)", ", rig limit max_thruster_command"
    return p.in_range(name, value, low=0, high=most, unit=unit, low_inclusive=True, why_high=why)


#: A request (the fields given) checked against the rig → the procedure's parameters.
calibration_parameters = CalibrationRequest.checked
