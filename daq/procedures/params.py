"""Validated parameters of every procedure, checked against the rig's limits
*before* the rig lock is taken or anything moves (Bluesky's ``check_value``).

Every error names the field, the value given and the allowed range, and is the
same object whether it reaches an operator through the CLI or a lab tool through
the HTTP API (as a 422 body).

One module because every kind's validator uses one checker, so the API and the CLI name
fields and ranges the same way for all of them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Literal

from daq.vocabulary import RunKind

if TYPE_CHECKING:  # annotations only: ``rig runs``/``rig show`` start without pydantic
    from pydantic import BaseModel

    from daq.config import RigConfig

#: Most steps one sequence may list (``repeats`` multiplies them, at most 100).
MAX_SEQUENCE_STEPS = 100


class ParameterError(ValueError):
    """One or more parameters are missing or out of range."""

    def __init__(self, problems: list[tuple[str, Any, str]]) -> None:
        self.problems = problems
        super().__init__("; ".join(self.lines()))

    def lines(self) -> list[str]:
        """One line per problem: ``field: value is not allowed (allowed …)``."""
        return [
            f"{name}: {_show(value)} is not allowed ({allowed})"
            for name, value, allowed in self.problems
        ]

    def to_json(self) -> list[dict[str, Any]]:
        """``[{"field", "value", "allowed", "message"}]`` for API error bodies."""
        return [
            {
                "field": name,
                "value": value if _json_safe(value) else str(value),
                "allowed": allowed,
                "message": line,
            }
            for (name, value, allowed), line in zip(self.problems, self.lines(), strict=True)
        ]


def _json_safe(value: Any) -> bool:
    return not (isinstance(value, float) and not math.isfinite(value))


def _show(value: Any) -> str:
    return "missing" if value is None else repr(value)


class _Checker:
    """Checks ``raw`` field by field; defaults not given are the request model's."""

    def __init__(self, raw: dict[str, Any], model: type[BaseModel] | None = None) -> None:
        self.raw = raw
        self.model = model
        self.problems: list[tuple[str, Any, str]] = []

    def default(self, name: str) -> Any:
        """The request model's default for ``name`` (``None``: none, or the rig decides)."""
        from daq.procedures.requests import field_default

        return None if self.model is None else field_default(self.model, name)

    def number(
        self,
        name: str,
        *,
        low: float,
        high: float,
        unit: str,
        low_inclusive: bool = False,
        default: float | None = None,
        required: bool = False,
        why_high: str = "",
        signed: bool = False,
    ) -> float | None:
        """The field as a float in ``low ⋯ high``; ``signed``: its magnitude is (a negative
        drive is a reverse test)."""
        value = self.raw.get(name, default if default is not None else self.default(name))
        lo_sym = "≤" if low_inclusive else "<"
        shown = f"|{name}|" if signed else name
        allowed = f"allowed {low:g} {lo_sym} {shown} ≤ {high:g} {unit}{why_high}"
        if signed:
            allowed += "; negative for a reverse test"
        if value is None:
            if required:
                self.problems.append((name, None, allowed))
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            try:
                value = float(value)
            except (TypeError, ValueError):
                self.problems.append((name, value, "a number; " + allowed))
                return None
        value = float(value)
        size = abs(value) if signed else value
        ok = (
            math.isfinite(value) and (size >= low if low_inclusive else size > low) and size <= high
        )
        if not ok:
            self.problems.append((name, value, allowed))
            return None
        return value

    def fail_if_problems(self) -> None:
        if self.problems:
            raise ParameterError(self.problems)


class _SignedLoad:
    """What a tow's and a spin's parameters share: a signed load (its sign is the test's
    direction) from a hung weight or from the thrusters, and the request it rounded."""

    hung_mass_kg: float | None
    requested: dict[str, float] | None
    #: The load's unit, for the operator's note.
    load_unit: ClassVar[str]

    @property
    def load(self) -> float:
        """The signed load: the tow's force (N) or the spin's torque (N·m)."""
        raise NotImplementedError

    def to_json(self) -> dict[str, Any]:
        return asdict(self)  # type: ignore[call-overload]  # subclasses are dataclasses

    def adjustment(self) -> str | None:
        """The sentence telling the operator the requested load was rounded, if it was."""
        return _adjustment(self.requested, self.hung_mass_kg, f"{self.load:.5g} {self.load_unit}")

    @property
    def reverse(self) -> bool:
        """A reverse test (negative load): a tow from the far end back toward the start, a
        spin with the cord wound the other way round the drum."""
        return self.load < 0


@dataclass(frozen=True)
class TowParameters(_SignedLoad):
    """A tow test: constant force from a weight over the pulley, or from the thrusters.

    A negative ``force_n`` is a reverse tow: the carriage starts at the far end
    (``Geometry.reverse_start``) and is pulled back, by a weight over the far-end pulley or
    by the thrusters; ``hung_mass_kg`` is the weight hung (positive) either way."""

    load_unit: ClassVar[str] = "N"

    force_n: float
    hung_mass_kg: float | None
    max_distance_m: float
    max_time_s: float
    baseline_s: float = 1.0
    drive: Literal["weight", "thrusters"] = "weight"
    kind: Literal[RunKind.TOW] = RunKind.TOW
    #: What was asked for when the hung weight (to the gram) changed it, e.g. {"force_n": 10}.
    requested: dict[str, float] | None = None

    @property
    def load(self) -> float:
        return self.force_n


@dataclass(frozen=True)
class SpinParameters(_SignedLoad):
    """A spin test: constant torque from a weight on the drum, or from the thrusters.

    A negative ``torque_nm`` is a reverse spin: the cord wound the other way round the drum
    (or the thrusters turning the other way); ``hung_mass_kg`` stays positive."""

    load_unit: ClassVar[str] = "N·m"

    torque_nm: float
    hung_mass_kg: float | None
    drive: Literal["weight", "thrusters"]
    max_angle_rad: float
    max_time_s: float
    baseline_s: float = 1.0
    kind: Literal[RunKind.SPIN] = RunKind.SPIN
    #: What was asked for when the hung weight (to the gram) changed it, e.g. {"torque_nm": 0.9}.
    requested: dict[str, float] | None = None

    @property
    def load(self) -> float:
        return self.torque_nm


@dataclass(frozen=True)
class CalibrationParameters:
    """A thrust calibration sweep on the load cell (up, then back down)."""

    commands: tuple[float, ...]
    settle_s: float = 1.0
    samples_per_step: int = 10
    tare_samples: int = 20
    reverse: bool = True
    kind: Literal[RunKind.THRUST_CALIBRATION] = RunKind.THRUST_CALIBRATION

    @property
    def sweep(self) -> list[float]:
        """Commands in the order applied: up then down (and the same for reverse)."""
        up = sorted(set(self.commands))
        order = up + up[-2::-1]
        if self.reverse:
            neg = [-c for c in up if c > 0]
            order += neg + neg[-2::-1] + [0.0]
        return order

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["commands"] = list(self.commands)
        d["sweep"] = self.sweep
        return d


#: Weights are hung (and known) to the gram: the force or torque recorded with a run is
#: what that weight gives, so the estimator's drive matches the rig's.
WEIGHT_RESOLUTION_KG = 0.001


_UNITS = {"force_n": "N", "torque_nm": "N·m", "weight_kg": "kg"}


def _adjustment(requested: dict[str, float] | None, mass_kg: float | None, load: str) -> str | None:
    if not requested or mass_kg is None:
        return None
    (name, value), *_ = requested.items()
    return (
        f"{name} {value:g} {_UNITS.get(name, '')} asked for; weights hang to the gram, so "
        f"{mass_kg:.3f} kg is hung and the run applies {load}"
    )


def _requested(name: str, value: float | None, applied: float) -> dict[str, float] | None:
    """``{name: value}`` when rounding the weight to the gram changed the request."""
    if value is None or math.isclose(value, applied, rel_tol=1e-9, abs_tol=1e-12):
        return None
    return {name: value}


def _hung_mass(c: _Checker, name: str, mass_kg: float | None) -> float:
    """The weight hung for a signed load in kg (its sign is the test's direction), to the
    gram; the weight itself is positive."""
    assert mass_kg is not None
    rounded = round(abs(mass_kg) / WEIGHT_RESOLUTION_KG) * WEIGHT_RESOLUTION_KG
    if rounded <= 0:
        c.problems.append((name, c.raw.get(name), "at least a 1 g weight's worth"))
        c.fail_if_problems()
    return round(rounded, 6)


def _drive_and_load(
    c: _Checker,
    *,
    test: str,
    name: str,
    unit: str,
    high: float,
    why_high: str,
    g: float,
    radius_m: float,
    why_weight_high: str,
) -> tuple[Any, float | None, float | None]:
    """A tow's or spin's ``drive`` (weight|thrusters) and its signed load, given as ``name``
    (up to ``high`` ``unit``) or as ``weight_kg`` (one kg hung gives ``g · radius_m``; a
    tow's radius is 1), not both; a thruster-driven test takes ``name``."""
    drive = c.raw.get("drive", c.default("drive"))
    if drive not in ("weight", "thrusters"):
        c.problems.append(("drive", drive, "allowed 'weight' or 'thrusters'"))
    load = c.number(name, low=0, high=high, unit=unit, why_high=why_high, signed=True)
    weight = c.number(
        "weight_kg",
        low=0,
        high=high / (g * radius_m),
        unit="kg",
        why_high=why_weight_high,
        signed=True,
    )
    given_weight = c.raw.get("weight_kg")
    if c.raw.get(name) is None and given_weight is None:
        c.problems.append((name, None, f"give {name} ({unit}) or weight_kg (kg)"))
    elif c.raw.get(name) is not None and given_weight is not None:
        c.problems.append(("weight_kg", given_weight, f"give {name} or weight_kg, not both"))
    elif drive == "thrusters" and given_weight is not None:
        c.problems.append(("weight_kg", given_weight, f"a thruster-driven {test} takes {name}"))
    return drive, load, weight


def _applied_load(
    c: _Checker,
    drive: str,
    name: str,
    load: float | None,
    weight: float | None,
    g: float,
    radius_m: float,
) -> tuple[float, float | None, dict[str, float] | None]:
    """The signed load the test applies, the weight hung (to the gram; ``None`` when the
    thrusters drive) and what was asked for if that weight changed it: a hung weight
    gives ``weight · g · radius_m``, the thrusters the load asked for."""
    if drive != "weight":
        assert load is not None
        return load, None, None
    asked = (name, load) if load is not None else ("weight_kg", weight)
    signed_kg = load / (g * radius_m) if load is not None else weight
    assert signed_kg is not None
    hung = _hung_mass(c, asked[0], signed_kg)
    applied = _clean(math.copysign(hung * g * radius_m, signed_kg))
    requested = _requested(*asked, applied if asked[0] == name else math.copysign(hung, signed_kg))
    return applied, hung, requested


#: Significant digits a derived load is stored with: far finer than a gram of weight
#: (1e-12 relative), coarse enough to drop binary float noise (83.30000000000001 → 83.3).
LOAD_DIGITS = 12


def _clean(value: float) -> float:
    """``value`` to :data:`LOAD_DIGITS` significant digits."""
    return float(f"{value:.{LOAD_DIGITS}g}")


def _max_time(c: _Checker, rig: RigConfig, why_high: str = "") -> float | None:
    """``max_time_s`` up to the rig's ``max_run_s`` (default 120 s or that limit)."""
    high = rig.limits.max_run_s
    return c.number(
        "max_time_s", low=0, high=high, unit="s", default=min(120.0, high), why_high=why_high
    )


def _baseline(c: _Checker) -> float | None:
    """``baseline_s``: the at-rest recording before the release, 0 … 30 s."""
    return c.number("baseline_s", low=0, high=30, unit="s", low_inclusive=True)


def tow_parameters(raw: dict[str, Any], rig: RigConfig) -> TowParameters:
    """Validate a tow request: ``force_n`` or ``weight_kg``; ``drive`` weight|thrusters."""
    from daq.procedures.requests import TowRequest

    c = _Checker(raw, TowRequest)
    g = rig.rig.g
    max_force = rig.limits.max_force_n
    drive, force, weight = _drive_and_load(
        c,
        test="tow",
        name="force_n",
        unit="N",
        high=max_force,
        why_high=", rig limit max_force_n",
        g=g,
        radius_m=1.0,
        why_weight_high=f", max_force_n / g = {max_force:g} N / {g:g}",
    )
    load = force if force is not None else weight
    if load is not None and load < 0:  # from the far end back toward the start
        room = rig.geometry.reverse_travel
        why = f", a reverse tow's room from {rig.geometry.reverse_start:g} m back to the start"
    else:
        room, why = rig.geometry.end_of_travel_m, ", end_of_travel_m"
    dist = c.number("max_distance_m", low=0, high=room, unit="m", default=room, why_high=why)
    tmax = _max_time(c, rig)
    base = _baseline(c)
    c.fail_if_problems()
    force, hung, requested = _applied_load(c, drive, "force_n", force, weight, g, 1.0)
    assert dist is not None and tmax is not None and base is not None
    return TowParameters(
        force_n=force,
        hung_mass_kg=hung,
        max_distance_m=dist,
        max_time_s=tmax,
        baseline_s=base,
        drive=drive,
        requested=requested,
    )


def spin_parameters(raw: dict[str, Any], rig: RigConfig) -> SpinParameters:
    """Validate a spin request: ``torque_nm`` or ``weight_kg``; ``drive`` weight|thrusters."""
    from daq.procedures.requests import SpinRequest

    c = _Checker(raw, SpinRequest)
    # A rig without a drum radius or torque limit cannot spin (``KindSpec.check`` refuses
    # first, naming what is missing); nan keeps a direct call from crashing here.
    g, r = rig.rig.g, rig.geometry.spin_drum_radius_m or math.nan
    drive, torque, weight = _drive_and_load(
        c,
        test="spin",
        name="torque_nm",
        unit="N·m",
        high=rig.limits.max_torque_nm or math.nan,
        why_high=", rig limit max_torque_nm",
        g=g,
        radius_m=r,
        why_weight_high=", max_torque_nm / (g · drum radius)",
    )
    amax = rig.geometry.spin_max_angle_rad
    angle = c.number(
        "max_angle_rad",
        low=0,
        high=amax,
        unit="rad",
        default=amax,
        why_high=", spin_max_angle_rad",
    )
    tmax = _max_time(c, rig)
    base = _baseline(c)
    c.fail_if_problems()
    torque, hung, requested = _applied_load(c, drive, "torque_nm", torque, weight, g, r)
    assert angle is not None and tmax is not None and base is not None
    return SpinParameters(
        torque_nm=torque,
        hung_mass_kg=hung,
        drive=drive,
        max_angle_rad=angle,
        max_time_s=tmax,
        baseline_s=base,
        requested=requested,
    )


def calibration_parameters(raw: dict[str, Any], rig: RigConfig) -> CalibrationParameters:
    """Validate a thrust-calibration request (commands as fractions of full scale)."""
    from daq.procedures.requests import (
        MAX_CALIBRATION_COMMANDS,
        THRUST_SWEEP_DEFAULT,
        CalibrationRequest,
    )

    c = _Checker(raw, CalibrationRequest)
    cmax = rig.limits.max_thruster_command
    commands = raw.get("commands", THRUST_SWEEP_DEFAULT)
    good: list[float] = []
    if not isinstance(commands, list | tuple) or not commands:
        c.problems.append(("commands", commands, f"a non-empty list of fractions 0 ≤ c ≤ {cmax:g}"))
    elif len(commands) > MAX_CALIBRATION_COMMANDS:
        c.problems.append(
            (
                "commands",
                f"a list of {len(commands)}",
                f"at most {MAX_CALIBRATION_COMMANDS} commands per calibration",
            )
        )
    else:
        for i, value in enumerate(commands):
            sub = _Checker({f"commands[{i}]": value})
            v = sub.number(
                f"commands[{i}]",
                low=0,
                high=cmax,
                unit="(fraction of full thrust)",
                low_inclusive=True,
                why_high=", rig limit max_thruster_command",
            )
            c.problems += sub.problems
            if v is not None:
                good.append(v)
    settle = c.number("settle_s", low=0, high=30, unit="s", low_inclusive=True)
    n = c.number("samples_per_step", low=1, high=1000, unit="samples", low_inclusive=True)
    tare = c.number("tare_samples", low=1, high=1000, unit="samples", low_inclusive=True)
    reverse = raw.get("reverse", c.default("reverse"))
    if not isinstance(reverse, bool):
        c.problems.append(("reverse", reverse, "true or false"))
    c.fail_if_problems()
    if 0.0 not in good:
        good.append(0.0)
    assert settle is not None and n is not None and tare is not None
    return CalibrationParameters(
        commands=tuple(sorted(good)),
        settle_s=settle,
        samples_per_step=int(n),
        tare_samples=int(tare),
        reverse=reverse,
    )


@dataclass(frozen=True)
class PendulumParameters:
    """A pendulum free-decay test: pull out to ``start_angle_rad``, release, record the decay."""

    start_angle_rad: float
    max_time_s: float
    stop_amplitude_rad: float = 0.005
    baseline_s: float = 1.0
    kind: Literal[RunKind.PENDULUM] = RunKind.PENDULUM

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


def pendulum_parameters(raw: dict[str, Any], rig: RigConfig) -> PendulumParameters:
    """Validate a free-decay request against the rig file's ``[pendulum]`` section."""
    if rig.pendulum is None:
        raise ParameterError(
            [("rig", rig.rig.name, "a rig file with a [pendulum] section (see docs/pendulum.md)")]
        )
    from daq.procedures.requests import PendulumRequest

    c = _Checker(raw, PendulumRequest)
    amax = rig.pendulum.max_angle_rad
    angle = c.number(
        "start_angle_rad",
        low=0,
        high=amax,
        unit="rad",
        required=True,
        why_high=", the rig's pendulum max_angle_rad",
    )
    tmax = _max_time(c, rig, ", rig limit max_run_s")
    stop = c.number(
        "stop_amplitude_rad",
        low=0,
        high=angle if angle is not None else amax,
        unit="rad",
        why_high=", start_angle_rad",
    )
    base = _baseline(c)
    c.fail_if_problems()
    assert angle is not None and tmax is not None and stop is not None and base is not None
    if stop >= angle:
        c.problems.append(
            ("stop_amplitude_rad", stop, f"allowed below start_angle_rad ({angle:g} rad)")
        )
        c.fail_if_problems()
    return PendulumParameters(
        start_angle_rad=angle, max_time_s=tmax, stop_amplitude_rad=stop, baseline_s=base
    )


@dataclass(frozen=True)
class Progress:
    """What a running procedure reports: 0..1 and a one-line message."""

    fraction: float
    message: str
    state: str = "running"
    extra: dict[str, Any] = field(default_factory=dict)
