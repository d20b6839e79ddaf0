"""What each procedure asks for, declared once as a pydantic model: the HTTP request
body (its OpenAPI schema), the ``rig`` command's options (``api.cli.options`` derives
them from the fields) and the keys a sequence step may hold.

A field's description is both the API's description and the CLI's help; its
:class:`Flag` says how the command line spells it. Limits that depend on the rig file
(``max_force_n``, end of travel, …) are checked by ``daq.procedures.params`` against
the rig, so every face gives the same message naming the field and the allowed range.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

THRUST_SWEEP_DEFAULT = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
#: Most command steps one calibration may sweep (each is held ``settle_s`` plus samples,
#: up and down, both directions): longer sweeps are split into several calibrations.
MAX_CALIBRATION_COMMANDS = 50


@dataclass(frozen=True)
class Flag:
    """How a request field is spelled on the command line.

    ``when_set``: the option is an on/off flag giving the field this value when present
    (``--thrusters`` → ``drive="thrusters"``); ``help`` then says what the flag does.
    ``parse`` turns the typed text into the field's value (``--commands 0,0.2`` → a list)."""

    name: str
    when_set: Any = None
    help: str | None = None
    metavar: str | None = None
    parse: Callable[[str], Any] | None = None


def comma_separated_floats(text: str) -> list[float]:
    """``"0,0.1,0.2"`` → ``[0.0, 0.1, 0.2]`` (``ValueError`` on anything else)."""
    return [float(part) for part in text.split(",")]


class _Strict(BaseModel):
    """A number must be a JSON number (``"24.5"`` is refused); unknown fields are refused;
    ``null`` is the field's default."""

    model_config = ConfigDict(strict=True, extra="forbid")


class RunMetadataIn(BaseModel):
    """Free metadata of a run (checked by ``daq.store.run_metadata``): the four keys below
    and any other lower-case key with a text, number or true/false value. In a PATCH a
    ``null`` removes the key."""

    model_config = ConfigDict(extra="allow")
    operator: str | None = Field(None, max_length=200, description="Who ran the test.")
    water_temperature_c: float | None = Field(None, description="Water temperature, °C (-2…50).")
    notes: str | None = Field(None, max_length=10_000)
    tags: list[str] | None = Field(
        None, max_length=20, description="Tags to find the run by, e.g. ['fins-v2']."
    )


class _ProcedureRequest(_Strict):
    """What every procedure start takes besides its own parameters (the CLI gives it with
    ``--operator``, ``--tag``, … from ``api.cli.metadata``, not from this field)."""

    metadata: RunMetadataIn | None = Field(
        None, description="Stored on every run the procedure records (see PATCH .../metadata)."
    )

    def parameters(self) -> dict[str, Any]:
        """The procedure's own parameters, as given (unset ones left out)."""
        return self.model_dump(exclude_none=True, exclude={"metadata"})

    def run_metadata(self) -> dict[str, Any] | None:
        """The ``metadata`` object as given (None when absent)."""
        return None if self.metadata is None else self.metadata.model_dump(exclude_unset=True)


Drive = Literal["weight", "thrusters"]
MaxTime = Annotated[
    float | None,
    Field(description="Stop after this many seconds (default 120)."),
    Flag("--max-time"),
]
Baseline = Annotated[
    float | None, Field(description="Pre-trigger baseline, s."), Flag("--baseline")
]


class TowRequest(_ProcedureRequest):
    """A tow test: ``force_n`` or ``weight_kg`` (force = weight × the rig's g); ``drive``
    weight|thrusters (thrusters: ``force_n`` through the calibrated inverse map). A negative
    load is a reverse tow: from the far end back toward the start (far-end pulley)."""

    force_n: Annotated[
        float | None,
        Field(
            description="Towing force in N, 0 < |F| ≤ the rig's max_force_n; negative: a "
            "reverse tow from the far end (far-end pulley, or thrusters turned round)."
        ),
        Flag("--force"),
    ] = None
    weight_kg: Annotated[
        float | None,
        Field(
            description="Hung weight in kg (force = weight × the rig's g); negative: hung on "
            "the far-end pulley (a reverse tow)."
        ),
        Flag("--weight"),
    ] = None
    drive: Annotated[
        Drive,
        Field(description="weight: a hung weight pulls; thrusters: the calibrated thrusters."),
        Flag(
            "--thrusters", "thrusters", "Drive the force with the calibrated thrusters (no weight)."
        ),
    ] = "weight"
    max_distance_m: Annotated[
        float | None,
        Field(
            description="Stop after this many metres (default: end of travel; a reverse tow: "
            "its room back to the start)."
        ),
        Flag("--max-distance"),
    ] = None
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0


class SpinRequest(_ProcedureRequest):
    """A spin test: ``torque_nm`` or ``weight_kg`` on the drum; ``drive`` weight|thrusters.
    A negative load is a reverse spin (the cord wound the other way round the drum)."""

    torque_nm: Annotated[
        float | None,
        Field(
            description="Torque in N·m, 0 < |τ| ≤ the rig's max_torque_nm; negative: a reverse "
            "spin (cord wound the other way, or thrusters turned round)."
        ),
        Flag("--torque"),
    ] = None
    weight_kg: Annotated[
        float | None,
        Field(
            description="Weight on the drum in kg (τ = weight × g × drum radius); negative: "
            "the cord wound the other way (a reverse spin)."
        ),
        Flag("--weight"),
    ] = None
    drive: Annotated[
        Drive,
        Field(description="weight: a weight on the drum turns; thrusters: the thrusters."),
        Flag("--thrusters", "thrusters", "Drive the torque with the calibrated thrusters."),
    ] = "weight"
    max_angle_rad: Annotated[
        float | None,
        Field(description="Stop after this angle, rad (default: cord length)."),
        Flag("--max-angle"),
    ] = None
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0


class PendulumRequest(_ProcedureRequest):
    """A pendulum free-decay test (needs a rig file with a ``[pendulum]`` section)."""

    start_angle_rad: Annotated[
        float | None,
        Field(
            description="Start angle, rad (0 < φ₀ ≤ the rig file's pendulum max_angle_rad); "
            "required."
        ),
        Flag("--angle"),
    ] = None
    stop_amplitude_rad: Annotated[
        float | None,
        Field(description="Stop once the amplitude over the last full cycle is below this, rad."),
        Flag("--stop-amplitude"),
    ] = 0.005
    max_time_s: MaxTime = None
    baseline_s: Baseline = 1.0


_SWEEP = ",".join(f"{c:g}" for c in THRUST_SWEEP_DEFAULT[:2]) + f",...,{THRUST_SWEEP_DEFAULT[-1]:g}"


class CalibrationRequest(_ProcedureRequest):
    """A thrust calibration sweep (commands as fractions of full thrust)."""

    commands: Annotated[
        list[float] | None,
        Field(
            max_length=MAX_CALIBRATION_COMMANDS,
            description=f"Command fractions, 0 ≤ c ≤ the rig's max_thruster_command, at most "
            f"{MAX_CALIBRATION_COMMANDS} (default {_SWEEP}); swept up then down, then reversed.",
        ),
        Flag("--commands", metavar="LIST", parse=comma_separated_floats),
    ] = None
    settle_s: Annotated[
        float | None, Field(description="Settling time per step, s."), Flag("--settle")
    ] = 1.0
    samples_per_step: Annotated[
        int | None, Field(description="Samples averaged per step."), Flag("--samples")
    ] = 10
    tare_samples: Annotated[
        int | None,
        Field(description="Samples averaged for the load cell's zero."),
        Flag("--tare-samples"),
    ] = 20
    reverse: Annotated[
        bool | None,
        Field(description="Also sweep the thrusters in reverse."),
        Flag("--no-reverse", False, "Forward sweep only."),
    ] = True


def field_default(model: type[BaseModel], name: str) -> Any:
    """The default a request model declares for ``name`` (``None``: the rig decides)."""
    info = model.model_fields.get(name)
    return None if info is None else info.default
