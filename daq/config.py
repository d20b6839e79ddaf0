"""Rig file: one TOML file per rig, validated once into typed objects.

The rig file is the single source of truth for where every channel lives on the
PLC and how its raw register words scale to SI units. Code never hard-codes an
address: it asks ``RigConfig.channel(name)``.
"""

from __future__ import annotations

import functools
import math
import tomllib
from pathlib import Path
from typing import Annotated, Any, Literal, TypeVar

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from daq.tolerances import Tolerances
from thrusters.settings import ThrusterPort

PACKAGE_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_RIG_FILE = PACKAGE_ROOT / "fixtures" / "rigs" / "benbam.toml"

#: A validated configuration model (the rig file, a simulation scenario).
ConfigModel = TypeVar("ConfigModel", bound=BaseModel)

RegisterKind = Literal["input", "holding", "coil", "discrete"]
DataType = Literal["uint16", "int16", "uint32", "int32", "float32", "bool"]
WordOrder = Literal["big", "little"]

#: Number of 16-bit registers each data type occupies.
REGISTER_WIDTH: dict[str, int] = {
    "uint16": 1,
    "int16": 1,
    "uint32": 2,
    "int32": 2,
    "float32": 2,
    "bool": 1,
}

# The channel names the code knows are declared where they are used, not listed here: each
# run kind's in its module (``KindSpec.needs``), the safety channels in
# ``daq.rig_capabilities``; a rig file lists only those its rig has (README, "Register map").

#: Channels a rig with a ``[pendulum]`` section defines (encoder and release latch).
PENDULUM_CHANNELS = ("pendulum_angle", "pendulum_release")

#: A reverse tow starts this far short of the end-of-travel switch (unless the rig file
#: says ``reverse_start_m``) and stops by distance this far short of the start buffer.
REVERSE_START_MARGIN_M = 0.1

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class RigConfigError(ValueError):
    """A rig or scenario file is missing a field or has a value out of range."""


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RigInfo(_Strict):
    name: str = Field(min_length=1)
    #: "simulated": the service starts the simulated rig and talks to it over
    #: real Modbus/serial; "hardware": connect to the endpoints given below.
    mode: Literal["simulated", "hardware"] = "simulated"
    #: Local gravitational acceleration used to turn hung masses into forces.
    g: Annotated[float, Field(gt=9.7, lt=9.9)] = 9.81


class Geometry(_Strict):
    rail_length_m: PositiveFloat
    #: Carriage position at which the end-of-travel switch trips; also the longest tow
    #: (``max_distance_m``), which is how a rig without the switch stops a tow.
    end_of_travel_m: PositiveFloat
    pulley_radius_m: PositiveFloat
    #: Rotational inertia of the tow pulley (adds J/r² to the towed mass).
    pulley_inertia_kg_m2: NonNegativeFloat = 0.0
    #: Radius the spin weight's cord acts at; a rig without a spin drum leaves it out
    #: (weight-driven spin tests then need it, see ``daq.rig_capabilities``).
    spin_drum_radius_m: PositiveFloat | None = None
    spin_drum_inertia_kg_m2: NonNegativeFloat = 0.0
    #: Largest yaw angle the spin cord allows before it is fully unwound.
    spin_max_angle_rad: PositiveFloat = 6 * math.pi
    #: Where a reverse tow starts: the carriage pushed to the far end, the tow line over the
    #: far-end pulley; it travels back toward 0 m. Default: 0.1 m short of end_of_travel_m.
    reverse_start_m: PositiveFloat | None = None

    @model_validator(mode="after")
    def _end_inside_rail(self) -> Geometry:
        if self.end_of_travel_m >= self.rail_length_m:
            raise ValueError(
                f"end_of_travel_m must be less than rail_length_m ({self.rail_length_m} m), "
                f"got {self.end_of_travel_m}"
            )
        if self.reverse_start_m is not None and self.reverse_start_m >= self.end_of_travel_m:
            raise ValueError(
                f"reverse_start_m must be less than end_of_travel_m ({self.end_of_travel_m} m), "
                f"got {self.reverse_start_m}"
            )
        return self

    @property
    def reverse_start(self) -> float:
        """Carriage position a reverse tow starts from, m."""
        if self.reverse_start_m is not None:
            return self.reverse_start_m
        return max(self.end_of_travel_m - REVERSE_START_MARGIN_M, 0.5 * self.end_of_travel_m)

    @property
    def reverse_travel(self) -> float:
        """Longest reverse tow, m: from ``reverse_start`` back to ``REVERSE_START_MARGIN_M``
        short of the buffer at 0 m (there is no switch at that end: it stops by distance)."""
        return max(self.reverse_start - REVERSE_START_MARGIN_M, 0.5 * self.reverse_start)


class Vehicle(_Strict):
    name: str = Field(min_length=1)
    dry_mass_kg: PositiveFloat


class ModbusConnection(_Strict):
    transport: Literal["tcp", "rtu"] = "tcp"
    host: str = "127.0.0.1"
    port: Annotated[int, Field(ge=0, le=65535)] = 5020
    #: RTU only: device path (``/dev/ttyUSB0``) or pyserial URL (``socket://host:port``).
    serial_port: str | None = None
    baudrate: Annotated[int, Field(ge=1200, le=921600)] = 115200
    parity: Literal["N", "E", "O"] = "N"
    stopbits: Literal[1, 2] = 1
    bytesize: Literal[7, 8] = 8
    unit_id: Annotated[int, Field(ge=0, le=247)] = 1
    #: Per-request timeout. Keep it well under the clock period.
    timeout_s: Annotated[float, Field(gt=0, le=5)] = 0.05
    #: Back-off bounds of the driver's own reconnect loop.
    reconnect_min_s: Annotated[float, Field(gt=0, le=10)] = 0.1
    reconnect_max_s: Annotated[float, Field(gt=0, le=60)] = 2.0
    #: How long opening the rig retries a PLC it cannot reach (with that back-off) before
    #: saying so; raise it for a PLC that is often still booting when a test starts.
    connect_timeout_s: Annotated[float, Field(gt=0, le=120)] = 3.0

    @model_validator(mode="after")
    def _rtu_needs_port(self) -> ModbusConnection:
        if self.transport == "rtu" and not self.serial_port:
            raise ValueError("serial_port is required when transport = 'rtu'")
        return self


class Channel(_Strict):
    name: str = Field(pattern=r"^[a-z][a-z0-9_]*$")
    kind: RegisterKind
    address: Annotated[int, Field(ge=0, le=65535)]
    type: DataType = "uint16"
    word_order: WordOrder = "big"
    #: SI value = raw * scale + offset.
    scale: Annotated[float, Field(allow_inf_nan=False)] = 1.0
    offset: Annotated[float, Field(allow_inf_nan=False)] = 0.0
    unit: str = ""
    #: A reading older than this is flagged stale.
    freshness_s: PositiveFloat = 0.5
    #: A counter that wraps (heartbeat, PLC clock): unwrap it on the host.
    wraps: bool = False
    #: Simulation-only register (operator acts the simulator lets a procedure play).
    sim_only: bool = False

    @property
    def width(self) -> int:
        """Registers occupied (bits count 1)."""
        return REGISTER_WIDTH[self.type]

    @model_validator(mode="after")
    def _type_matches_kind(self) -> Channel:
        is_bit = self.kind in ("coil", "discrete")
        if is_bit != (self.type == "bool"):
            allowed = "'bool'" if is_bit else "'uint16', 'int16', 'uint32', 'int32', 'float32'"
            raise ValueError(
                f"channel {self.name!r}: kind {self.kind!r} needs type {allowed}, got {self.type!r}"
            )
        if self.scale == 0:
            raise ValueError(f"channel {self.name!r}: scale must not be 0")
        last = 65535 - (self.width - 1)
        if self.address > last:
            raise ValueError(
                f"channel {self.name!r}: address {self.address} does not fit a {self.type} "
                f"({self.width} registers); allowed address 0..{last}"
            )
        return self


class Limits(_Strict):
    max_force_n: PositiveFloat
    #: Largest spin torque; a rig without a spin axis leaves it out (spin tests need it).
    max_torque_nm: PositiveFloat | None = None
    #: Largest thruster command the host sends, as a fraction of full scale (0..1).
    max_thruster_command: Annotated[float, Field(gt=0, le=1)] = 0.8
    #: Largest change of thruster command per second (fraction of full scale per s).
    max_command_slew_per_s: PositiveFloat = 2.0
    max_speed_m_s: PositiveFloat
    max_yaw_rate_rad_s: PositiveFloat = 3.0
    max_run_s: PositiveFloat = 600.0


class Acquisition(_Strict):
    rate_hz: Annotated[float, Field(ge=0.5, le=1000)] = 10.0
    #: Batch flush interval of the run recorder (≤ 1 s by design).
    flush_interval_s: Annotated[float, Field(gt=0, le=1.0)] = 0.5


class Pendulum(_Strict):
    """A physical pendulum carrying the vehicle: free-decay tests (seed 002, §4.4.1).

    The swing obeys ``(J_t + m_z l² + J_v + α l²) φ̈ = −[(m_z − ρV) l + m_t r] g sin φ − …``
    (``docs/pendulum.md``); the vehicle's mass is ``[vehicle] dry_mass_kg``.
    """

    #: l: pivot to the vehicle's centre of gravity, m.
    pivot_to_vehicle_m: Annotated[float, Field(gt=0, le=10, allow_inf_nan=False)]
    #: m_t: rod (+ clamp) mass, kg.
    rod_mass_kg: Annotated[float, Field(ge=0, le=500, allow_inf_nan=False)]
    #: r: pivot to the rod's centre of gravity, m.
    rod_cg_m: Annotated[float, Field(ge=0, le=10, allow_inf_nan=False)]
    #: J_t: rod (+ clamp) about the pivot, kg·m² (measured by a rod-only swing).
    rod_inertia_kg_m2: Annotated[float, Field(ge=0, le=1_000, allow_inf_nan=False)]
    #: J_v: the vehicle about its own centre of gravity, about the swing axis, kg·m².
    vehicle_inertia_kg_m2: Annotated[float, Field(ge=0, le=1_000, allow_inf_nan=False)]
    #: ρ·V: mass of the water the vehicle displaces, kg (buoyancy acts at the vehicle's CG).
    buoyancy_kg: Annotated[float, Field(ge=0, le=10_000, allow_inf_nan=False)]
    #: b: known viscous torque of pivot and rod per angular speed, N·m·s/rad (0: not measured).
    pivot_damping_nm_s: Annotated[float, Field(ge=0, le=1_000, allow_inf_nan=False)] = 0.0
    #: Largest start angle a test may pull the pendulum out to, rad.
    max_angle_rad: Annotated[float, Field(gt=0, le=1.2, allow_inf_nan=False)] = 0.5
    #: The vehicle axis that moves through the water as the pendulum swings.
    axis: Literal["surge", "sway", "heave"] = "surge"

    @model_validator(mode="after")
    def _rod_inertia_physical(self) -> Pendulum:
        # A body's inertia about the pivot is at least that of its mass at its CG.
        least = self.rod_mass_kg * self.rod_cg_m**2
        if self.rod_inertia_kg_m2 < least * (1 - 1e-9):
            raise ValueError(
                f"rod_inertia_kg_m2 must be at least rod_mass_kg · rod_cg_m² ({least:.4g} kg·m²), "
                f"got {self.rod_inertia_kg_m2}"
            )
        return self


class RigConfig(_Strict):
    rig: RigInfo
    geometry: Geometry
    vehicle: Vehicle
    modbus: ModbusConnection
    channels: list[Channel] = Field(min_length=1)
    #: Optional: the thruster controller (thruster-driven tests and calibration need it).
    thrusters: ThrusterPort | None = None
    limits: Limits
    acquisition: Acquisition = Acquisition()
    #: Optional: a pendulum for free-decay tests (needs the pendulum channels).
    pendulum: Pendulum | None = None
    #: Optional: tolerances of the rig's constants (Type B uncertainty); absent: not declared.
    tolerances: Tolerances | None = None

    @field_validator("channels")
    @classmethod
    def _unique_and_non_overlapping(cls, channels: list[Channel]) -> list[Channel]:
        names = [c.name for c in channels]
        dupes = sorted({n for n in names if names.count(n) > 1})
        if dupes:
            raise ValueError(f"channel names must be unique; repeated: {', '.join(dupes)}")
        used: dict[tuple[str, int], str] = {}
        for ch in channels:
            for a in range(ch.address, ch.address + ch.width):
                key = (ch.kind, a)
                if key in used:
                    raise ValueError(
                        f"channel {ch.name!r} overlaps {used[key]!r} at {ch.kind} address {a}"
                    )
                used[key] = ch.name
        return channels

    @model_validator(mode="after")
    def _pendulum_channels_present(self) -> RigConfig:
        if self.pendulum is None:
            return self
        names = {c.name for c in self.channels}
        missing = [n for n in PENDULUM_CHANNELS if n not in names]
        if missing:
            raise ValueError(
                f"channels: a rig with [pendulum] needs channel(s) {', '.join(missing)}"
            )
        p = self.pendulum
        righting = (self.vehicle.dry_mass_kg - p.buoyancy_kg) * p.pivot_to_vehicle_m
        righting += p.rod_mass_kg * p.rod_cg_m
        if righting <= 0:
            raise ValueError(
                "pendulum: (dry_mass_kg − buoyancy_kg) · pivot_to_vehicle_m + rod_mass_kg · "
                f"rod_cg_m must be positive (a restoring moment), got {righting:.4g} kg·m"
            )
        return self

    def thruster_port(self) -> ThrusterPort:
        """The ``[thrusters]`` section; RigConfigError when the rig file has none."""
        if self.thrusters is None:
            raise RigConfigError(
                f"rig {self.rig.name!r} has no thrusters (its rig file has no [thrusters] section)"
            )
        return self.thrusters

    def has(self, name: str) -> bool:
        """The rig file lists a channel called ``name`` (simulation-only ones included)."""
        return any(c.name == name for c in self.channels)

    def channel(self, name: str) -> Channel:
        """The channel called ``name``; KeyError names the known channels."""
        for ch in self.channels:
            if ch.name == name:
                return ch
        raise KeyError(f"no channel {name!r}; known: {', '.join(c.name for c in self.channels)}")

    def channels_of(self, kind: RegisterKind, *, sim_only: bool | None = False) -> list[Channel]:
        """Channels of one register kind, sorted by address."""
        out = [
            c
            for c in self.channels
            if c.kind == kind and (sim_only is None or c.sim_only == sim_only)
        ]
        return sorted(out, key=lambda c: c.address)


def format_validation_error(source: str, err: ValidationError) -> str:
    """One line per problem: ``<source>: <field.path>: <message> (got <value>)``."""
    lines = []
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        msg = e["msg"].removeprefix("Value error, ")
        got = e.get("input")
        shown = "" if isinstance(got, dict | list) or got is None else f" (got {got!r})"
        if e["type"] == "missing":
            msg = "field required"
        lines.append(f"{source}: {loc}: {msg}{shown}")
    return "\n".join(lines)


def validate_config(model: type[ConfigModel], data: dict, source: str) -> ConfigModel:
    """``data`` validated into ``model``; RigConfigError naming each bad field of ``source``."""
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise RigConfigError(format_validation_error(source, err)) from None


def read_toml_file(path: Path, what: str) -> dict[str, Any]:
    """The tables of the TOML file at ``path``; RigConfigError naming the file and ``what``
    it should be ("rig file") when it cannot be read, is not UTF-8 or not TOML."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as err:
        raise RigConfigError(f"{path}: cannot read {what} ({err.strerror})") from None
    except UnicodeDecodeError as err:
        raise RigConfigError(
            f"{path}: not a {what}: not UTF-8 text ({err.reason} at byte {err.start})"
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise RigConfigError(f"{path}: not valid TOML: {err}") from None


def parse_rig(data: dict, source: str = "rig file") -> RigConfig:
    """Validate a rig-file dictionary; raises RigConfigError naming each bad field."""
    return validate_config(RigConfig, data, source)


@functools.lru_cache(maxsize=8)
def _rig_of_text(text: str) -> RigConfig:
    """``text`` parsed and validated, once per distinct text (a frozen model, safe to share)."""
    return parse_rig(tomllib.loads(text))


def parse_rig_text(text: str, source: str) -> RigConfig:
    """The rig file whose text is ``text`` (a run's stored ``rig_toml``), parsed once per
    distinct text: an estimate's steps each ask for their runs' rig, and a campaign's runs
    share one text. Raises RigConfigError naming ``source`` and each bad field."""
    try:
        return _rig_of_text(text)
    except tomllib.TOMLDecodeError as err:
        raise RigConfigError(f"{source}: not valid TOML: {err}") from None
    except RigConfigError:  # not cached: validated again to name its source
        return parse_rig(tomllib.loads(text), source)


def load_rig(path: str | Path | None = None) -> RigConfig:
    """Load and validate a rig file (default: the BENBAM rig of seed 000)."""
    p = Path(path) if path else DEFAULT_RIG_FILE
    return parse_rig(read_toml_file(p, "rig file"), str(p))
