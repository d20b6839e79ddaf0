"""Simulation scenario: the plant's coefficients, rig effects and sensor realism.

A scenario file (TOML) overrides the default coefficients (seed 000, Table 1,
approach 3) and switches on effects the estimation model does not have. Every
effect is off by default, so an empty file is the clean plant. See
``docs/simulated-rig.md`` for every key, its unit and default.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

from daq.config import PACKAGE_ROOT, read_toml_file, validate_config

SCENARIO_DIR = PACKAGE_ROOT / "fixtures" / "scenarios"

NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
Finite = Annotated[float, Field(allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SurgeCoefficients(_Strict):
    """Surge (tow) axis of the vehicle alone: ``(m+m_a) v̇ + K_L v + K_Q |v| v = F``."""

    inertia_kg: Annotated[float, Field(gt=0, le=10_000)] = 143.26
    linear_damping: Annotated[float, Field(ge=0, le=10_000)] = 20.16
    quadratic_damping: Annotated[float, Field(ge=0, le=100_000)] = 241.14


class TranslationCoefficients(_Strict):
    """Another translational axis of the vehicle (sway, heave): seen only by the pendulum."""

    inertia_kg: Annotated[float, Field(gt=0, le=10_000)]
    linear_damping: Annotated[float, Field(ge=0, le=10_000)]
    quadratic_damping: Annotated[float, Field(ge=0, le=100_000)]


class YawCoefficients(_Strict):
    """Yaw (spin) axis: ``I ω̇ + K_L ω + K_Q |ω| ω = τ``."""

    inertia_kg_m2: Annotated[float, Field(gt=0, le=1_000)] = 7.97
    linear_damping: Annotated[float, Field(ge=0, le=1_000)] = 0.119
    quadratic_damping: Annotated[float, Field(ge=0, le=10_000)] = 4.12


class Effects(_Strict):
    """Rig effects outside the estimation model; all off (zero) by default."""

    #: Carriage Coulomb (sliding) friction, N, opposing motion.
    coulomb_friction_n: Annotated[float, Field(ge=0, le=100)] = 0.0
    #: Carriage break-away (static) friction, N; 0 means equal to the Coulomb level.
    static_friction_n: Annotated[float, Field(ge=0, le=100)] = 0.0
    yaw_coulomb_friction_nm: Annotated[float, Field(ge=0, le=10)] = 0.0
    yaw_static_friction_nm: Annotated[float, Field(ge=0, le=10)] = 0.0
    #: Constant force/torque of a current in the tank (does not flip with direction).
    bias_force_n: Annotated[float, Field(ge=-100, le=100)] = 0.0
    bias_torque_nm: Annotated[float, Field(ge=-10, le=10)] = 0.0
    #: Restoring spring on position (N/m) and yaw (tether torsion, N·m/rad).
    spring_n_per_m: Annotated[float, Field(ge=0, le=1_000)] = 0.0
    spring_nm_per_rad: Annotated[float, Field(ge=0, le=100)] = 0.0
    #: Tow-rope stiffness between weight and carriage, N/m; 0 = rigid rope.
    rope_stiffness_n_per_m: Annotated[float, Field(ge=0, le=1e6)] = 0.0
    #: Internal damping of an elastic rope, N·s/m (used only when the rope is elastic).
    rope_damping_n_s_per_m: Annotated[float, Field(ge=0, le=1_000)] = 2.0
    #: Cubic drag, N·s³/m³ (surge) and N·m·s³/rad³ (yaw).
    cubic_drag: Annotated[float, Field(ge=0, le=10_000)] = 0.0
    yaw_cubic_drag: Annotated[float, Field(ge=0, le=1_000)] = 0.0
    #: Time between setting a release coil and the brake actually letting go, s.
    release_delay_s: Annotated[float, Field(ge=0, le=10)] = 0.0
    #: Dry (Coulomb) friction torque in the pendulum's pivot, N·m, and its break-away
    #: (static) level; 0 means equal to the Coulomb level.
    pivot_coulomb_friction_nm: Annotated[float, Field(ge=0, le=50)] = 0.0
    pivot_static_friction_nm: Annotated[float, Field(ge=0, le=50)] = 0.0

    @model_validator(mode="after")
    def _static_not_below_coulomb(self) -> Effects:
        pairs = (
            ("static_friction_n", "coulomb_friction_n"),
            ("yaw_static_friction_nm", "yaw_coulomb_friction_nm"),
            ("pivot_static_friction_nm", "pivot_coulomb_friction_nm"),
        )
        for static, coulomb in pairs:
            s, c = getattr(self, static), getattr(self, coulomb)
            if 0 < s < c:
                raise ValueError(f"{static} must be 0 or at least {coulomb} ({c}), got {s}")
        return self


class Sensors(_Strict):
    """Sensor realism: encoder resolution, noise, offsets, timing."""

    #: Tow encoder resolution (10 000 counts/m = 0.1 mm steps).
    encoder_counts_per_m: Annotated[float, Field(ge=100, le=1e7)] = 10_000.0
    #: Yaw encoder resolution (16 384 counts per revolution).
    encoder_counts_per_rad: Annotated[float, Field(ge=10, le=1e7)] = 16_384 / (2 * math.pi)
    #: Pendulum angle encoder resolution (17 bits per revolution) and its noise, rad.
    pendulum_counts_per_rad: Annotated[float, Field(ge=10, le=1e7)] = 131_072 / (2 * math.pi)
    pendulum_angle_noise_rad: Annotated[float, Field(ge=0, le=0.1)] = 0.0
    #: Load-cell noise (standard deviation, N) and zero offset (N).
    load_cell_noise_n: Annotated[float, Field(ge=0, le=10)] = 0.05
    load_cell_offset_n: Annotated[float, Field(ge=-100, le=100)] = 0.3
    #: Each PLC response is delayed by a random time in [0, timestamp_jitter_s], s.
    timestamp_jitter_s: Annotated[float, Field(ge=0, le=0.5)] = 0.0
    #: Supply voltage with no load, V, and its noise (standard deviation, V).
    supply_voltage_v: Annotated[float, Field(ge=6, le=60)] = 16.0
    supply_voltage_noise_v: Annotated[float, Field(ge=0, le=2)] = 0.02
    #: Supply source resistance, ohm: the voltage sags with thruster current.
    supply_resistance_ohm: Annotated[float, Field(ge=0, le=1)] = 0.02


class ThrusterModel(_Strict):
    """Thrust vs command: ``T = F_fs · s^exponent · (V/V_nom)^voltage_exponent``, lagged."""

    #: Commands with |u| at or below this fraction of full scale give no thrust.
    dead_band: Annotated[float, Field(ge=0, le=0.5)] = 0.05
    #: Reverse thrust as a fraction of forward thrust at equal command.
    reverse_ratio: Annotated[float, Field(gt=0, le=1.5)] = 0.78
    #: Curve exponent on the command above the dead band; < 1 is concave.
    curve_exponent: Annotated[float, Field(gt=0.3, le=3)] = 0.8
    #: First-order lag of thrust behind command, s.
    time_constant_s: Annotated[float, Field(ge=0, le=5)] = 0.15
    #: Full-scale thrust at nominal voltage, N; None = the rig file's value.
    full_scale_thrust_n: Annotated[float, Field(gt=0, le=10_000)] | None = None
    nominal_voltage_v: Annotated[float, Field(ge=6, le=60)] = 16.0
    voltage_exponent: Annotated[float, Field(ge=0, le=3)] = 1.5
    #: Telemetry: propeller speed and current at full-scale thrust.
    full_scale_rpm: Annotated[float, Field(gt=0, le=100_000)] = 3500.0
    full_scale_current_a: Annotated[float, Field(gt=0, le=200)] = 12.0


class Scenario(_Strict):
    """Everything the simulated rig needs beyond the rig file."""

    name: str = "clean"
    description: str = ""
    surge: SurgeCoefficients = SurgeCoefficients()
    yaw: YawCoefficients = YawCoefficients()
    #: Sway and heave: only a pendulum swinging along that axis needs them.
    sway: TranslationCoefficients | None = None
    heave: TranslationCoefficients | None = None
    effects: Effects = Effects()
    sensors: Sensors = Sensors()
    thrusters: ThrusterModel = ThrusterModel()
    #: Seed of every random draw (noise, jitter): equal seeds give equal runs.
    seed: Annotated[int, Field(ge=0)] = 0


def parse_scenario(data: dict, source: str = "scenario file") -> Scenario:
    """Validate a scenario dictionary; raises RigConfigError naming each bad field."""
    return validate_config(Scenario, data, source)


def load_scenario(path: str | Path | None = None) -> Scenario:
    """Load and validate a scenario TOML file (None: the clean default scenario)."""
    if path is None:
        return Scenario()
    p = Path(path)
    data = read_toml_file(p, "scenario file")
    data.setdefault("name", p.stem)
    return parse_scenario(data, str(p))
