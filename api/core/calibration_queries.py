"""What a thrust-stand table import and a thrust-law question take, each parameter declared
once (range, help, option) for ``POST /api/calibrations/import`` and ``rig
import-calibration`` (:class:`StandTableQuery`), ``GET /api/thrust`` and ``rig thrust``
(:class:`ThrustQuery`, and which calibration answers: :class:`CalibrationChoice`)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, ClassVar, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from estimation.thrust.calibration_import import (
    COMMAND_UNITS,
    THRUST_UNITS,
    CommandUnit,
    ImportSpec,
    stand_columns,
)

if TYPE_CHECKING:  # a law is only passed in
    from estimation.thrust.law import ThrustLaw

CommandUnitName = Literal[COMMAND_UNITS]  # type: ignore[valid-type]
ThrustUnitName = Literal[tuple(THRUST_UNITS)]  # type: ignore[valid-type]
#: A column is named by its header text or its 1-based number.
Column = Annotated[str, Field(min_length=1, max_length=200)]


class StandTableQuery(BaseModel):
    """Which columns of a thrust-stand table hold what, in which unit, and its name."""

    model_config = ConfigDict(frozen=True)

    command_column: Annotated[
        Column,
        Field(description="Header (or 1-based number) of the command column."),
        Flag("--command-column"),
    ] = "1"
    command_unit: Annotated[
        CommandUnitName,  # type: ignore[valid-type]
        Field(description="pwm_us (with --pwm-neutral/--pwm-span), permille, fraction "
              "(−1 … 1) or volts (with --full-scale)."),
        Flag("--command-unit"),
    ] = "fraction"  # fmt: skip
    pwm_neutral_us: Annotated[
        float, Field(description="PWM pulse of zero command, µs."), Flag("--pwm-neutral")
    ] = 1500.0
    pwm_span_us: Annotated[
        float, Field(gt=0, description="µs from neutral to full command."), Flag("--pwm-span")
    ] = 400.0
    full_scale_v: Annotated[
        float | None,
        Field(gt=0, description="Command voltage of full command, V (command unit volts)."),
        Flag("--full-scale"),
    ] = None
    thrust_column: Annotated[
        Column,
        Field(description="Header (or 1-based number) of the thrust column."),
        Flag("--thrust-column"),
    ] = "2"
    thrust_unit: Annotated[
        ThrustUnitName,  # type: ignore[valid-type]
        Field(description="Unit of the thrust column."),
        Flag("--thrust-unit"),
    ] = "N"
    voltage_column: Annotated[
        Column | None,
        Field(description="Header (or number) of the supply-voltage column."),
        Flag("--voltage-column"),
    ] = None
    voltage_v: Annotated[
        float | None,
        Field(gt=0, le=1000,
              description="Supply voltage of the whole table, V (when it has no voltage "
              "column)."),
        Flag("--voltage"),
    ] = None  # fmt: skip
    current_column: Annotated[
        Column | None,
        Field(description="Header (or number) of a current column (A)."),
        Flag("--current-column"),
    ] = None
    rpm_column: Annotated[
        Column | None,
        Field(description="Header (or number) of an RPM column (rev/min)."),
        Flag("--rpm-column"),
    ] = None
    power_column: Annotated[
        Column | None,
        Field(description="Header (or number) of an electrical power column (W)."),
        Flag("--power-column"),
    ] = None
    name: Annotated[
        str | None,
        Field(min_length=1, max_length=200,
              description="Name to store it under (default: the file's name)."),
        Flag("--name"),
    ] = None  # fmt: skip

    def spec(self) -> ImportSpec:
        """The table's columns and units as ``estimation.thrust.calibration_import`` reads
        them (``ValueError`` naming the field for a combination it refuses)."""
        return ImportSpec(
            command_column=self.command_column,
            thrust_column=self.thrust_column,
            thrust_unit=self.thrust_unit,
            command=CommandUnit(
                self.command_unit, self.pwm_neutral_us, self.pwm_span_us, self.full_scale_v
            ),
            voltage_column=self.voltage_column,
            voltage_v=self.voltage_v,
            extra_columns=stand_columns(
                current_a=self.current_column, rpm=self.rpm_column, power_w=self.power_column
            ),
        )


class ThrustQuery(BaseModel):
    """A question to the thrust law: the force at ``command``, or the command for
    ``force_n`` (exactly one), at the supply ``voltage_v``."""

    model_config = ConfigDict(frozen=True)
    #: Exactly one of these fields is given (:meth:`check`; the docs' ``--command C |
    #: --force N``).
    exactly_one_of: ClassVar[tuple[str, ...]] = ("command", "force_n")

    command: Annotated[
        float | None,
        Field(ge=-1, le=1, description="Command, fraction of full command: give the force."),
        Flag("--command", metavar="C"),
    ] = None
    force_n: Annotated[
        float | None,
        Field(allow_inf_nan=False, description="Force per thruster, N: give the command."),
        Flag("--force"),
    ] = None
    voltage_v: Annotated[
        float | None,
        Field(gt=0, le=1000,
              description="Supply voltage, V (default: the supply the rig recorded last, else "
              "the calibration's reference voltage; the answer's voltage_source says which)."),
        Flag("--voltage"),
    ] = None  # fmt: skip

    def check(self) -> None:
        """``ValueError`` naming the fields of :attr:`exactly_one_of` unless exactly one of
        them is given."""
        if sum(getattr(self, name) is not None for name in self.exactly_one_of) != 1:
            raise ValueError(f"{' or '.join(self.exactly_one_of)}: give exactly one")

    def answer(self, law: ThrustLaw, volts: float) -> dict[str, Any]:
        """The law's answer at ``volts``: the given quantity as given, the other as
        ``{value, std}``, and ``voltage_law`` (how the voltage entered). ``ValueError``
        naming the field when neither or both are given, or for a force beyond what full
        command delivers at that voltage."""
        self.check()
        if self.command is not None:
            out = law.estimate(self.command, volts)
            return {"command": self.command, "force_n": out.to_json(),
                    "voltage_law": out.voltage_law}  # fmt: skip
        assert self.force_n is not None
        try:
            out = law.command_for_force(self.force_n, volts)
        except ValueError as err:
            raise ValueError(f"force_n: {str(err).removeprefix('force: ')}") from None
        return {"force_n": self.force_n, "command": out.to_json(), "voltage_law": out.voltage_law}


#: How ``calibration`` names one: an imported table's id, or ``run:`` and a result's id.
CALIBRATION_FORM = "ID or run:ID, e.g. 3 or run:12"


class CalibrationChoice(BaseModel):
    """Which stored thrust calibration answers (default: the newest, imported or measured):
    ``calibration`` as ``rig thrust --calibration`` and ``GET /api/thrust?calibration=``
    spell it, read once into ``source`` and ``calibration_id`` (which the route also takes
    as they are)."""

    model_config = ConfigDict(frozen=True)

    calibration: Annotated[
        str | None,
        Field(max_length=40,
              description="Imported calibration id, or run:ID for a calibration run's result "
              "(default: the newest of both)."),
        Flag("--calibration", metavar="ID|run:ID"),
    ] = None  # fmt: skip
    source: Annotated[
        Literal["imported", "run"] | None,
        Field(description="What calibration_id numbers (the long form of calibration)."),
    ] = None
    calibration_id: Annotated[
        int | None,
        Field(ge=1, description="The calibration's id (with source; the long form of "
              "calibration)."),
    ] = None  # fmt: skip

    @model_validator(mode="before")
    @classmethod
    def _read_calibration(cls, given: Any) -> Any:
        """``calibration`` (``3``, ``imported:3``, ``run:12``) → ``source``, ``calibration_id``."""
        if not isinstance(given, dict) or given.get("calibration") is None:
            return given
        text = given["calibration"]
        if given.get("source") is not None or given.get("calibration_id") is not None:
            raise ParameterError([("calibration", text, "give it or source with "
                                   "calibration_id, not both")])  # fmt: skip
        prefix, _, key = str(text).rpartition(":")
        source = {"": "imported", "imported": "imported", "run": "run"}.get(prefix.strip())
        key = key.strip()
        if source is None or not key.isdigit() or int(key) < 1:
            raise ParameterError([("calibration", text, CALIBRATION_FORM)])
        return given | {"source": source, "calibration_id": int(key)}

    def label(self) -> str:
        """How errors name the calibration asked for (``newest``, ``run 12``)."""
        return "newest" if self.calibration_id is None else f"{self.source} {self.calibration_id}"
