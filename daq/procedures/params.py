"""How a procedure's parameters are refused, and the arithmetic of a hung load.

The parameters themselves are the request models of ``daq.procedures.requests``, checked
against the rig file by pydantic validators that read the rig from the validation context
(``TowRequest.checked(raw, rig)``) *before* the rig lock is taken or anything moves
(Bluesky's ``check_value``). Every refusal is a :class:`ParameterError` naming the field,
the value given and the allowed range, the same object whether it reaches an operator
through the CLI or a lab tool through the HTTP API (as a 422 body).

Light on purpose (no pydantic at import): ``rig runs`` and the CLI's error handling
import it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, overload

if TYPE_CHECKING:
    from daq.config import RigConfig

#: Most steps one sequence may list (``repeats`` multiplies them, at most 100).
MAX_SEQUENCE_STEPS = 100
#: Longest rest between a sequence's runs, s.
MAX_REST_S = 3600
#: Weights are hung (and known) to the gram: the force or torque recorded with a run is
#: what that weight gives, so the estimator's drive matches the rig's.
WEIGHT_RESOLUTION_KG = 0.001
#: Significant digits a derived load is stored with: far finer than a gram of weight
#: (1e-12 relative), coarse enough to drop binary float noise (83.30000000000001 → 83.3).
LOAD_DIGITS = 12

Problem = tuple[str, Any, str]


class ParameterError(ValueError):
    """One or more parameters are missing or out of range."""

    def __init__(self, problems: list[Problem]) -> None:
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


def check_rest(rest: Any) -> float:
    """A sequence's rest between runs: a number 0 … ``MAX_REST_S`` s (a file's ``rest_s``,
    the body's, ``rig sequence --rest``); ``ParameterError`` naming ``rest_s``."""
    if isinstance(rest, bool) or not isinstance(rest, int | float) or not 0 <= rest <= MAX_REST_S:
        raise ParameterError([("rest_s", rest, f"allowed 0 ≤ rest_s ≤ {MAX_REST_S} s")])
    return float(rest)


def _json_safe(value: Any) -> bool:
    return not (isinstance(value, float) and not math.isfinite(value))


def _show(value: Any) -> str:
    return "missing" if value is None else repr(value)


def problems_of(error: Any) -> list[Problem]:
    """The problems of a pydantic ``ValidationError``: a validator's own
    :class:`ParameterError` as it named them, any other error as (field, value, message)."""
    problems: list[Problem] = []
    for e in error.errors():
        raised = (e.get("ctx") or {}).get("error")
        if isinstance(raised, ParameterError):
            problems += raised.problems
            continue
        name = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in e["loc"]).lstrip(".")
        value, allowed = e.get("input"), e["msg"]
        if e["type"] == "too_long":  # "at most 50 commands", not the whole list echoed
            value = f"a list of {e['ctx']['actual_length']}"
            allowed = f"at most {e['ctx']['max_length']} {name.split('.')[-1]}"
        problems.append((name or "request", value, allowed))
    return problems


@overload
def in_range(
    name: str, value: float, *, low: float, high: float, unit: str, low_inclusive: bool = ...,
    default: float | None = ..., required: bool = ..., why_high: str = ..., signed: bool = ...,
) -> float: ...  # fmt: skip
@overload
def in_range(
    name: str, value: float | None, *, low: float, high: float, unit: str,
    low_inclusive: bool = ..., default: float | None = ..., required: bool = ...,
    why_high: str = ..., signed: bool = ...,
) -> float | None: ...  # fmt: skip


def in_range(
    name: str,
    value: float | None,
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
    """``value`` (else ``default``) as a float in ``low ⋯ high`` (``signed``: its
    magnitude; a negative drive is a reverse test), or ``ParameterError`` naming the range.
    ``None`` stays ``None`` unless ``required``."""
    lo_sym = "≤" if low_inclusive else "<"
    shown = f"|{name}|" if signed else name
    allowed = f"allowed {low:g} {lo_sym} {shown} ≤ {high:g} {unit}{why_high}"
    if signed:
        allowed += "; negative for a reverse test"
    if value is None:
        value = default
    if value is None:
        if required:
            raise ParameterError([(name, None, allowed)])
        return None
    value = float(value)
    size = abs(value) if signed else value
    ok = math.isfinite(value) and (size >= low if low_inclusive else size > low) and size <= high
    if not ok:
        raise ParameterError([(name, value, allowed)])
    return value


def max_time(value: float | None, rig: RigConfig, why_high: str = "") -> float | None:
    """``max_time_s`` up to the rig's ``max_run_s`` (default 120 s or that limit)."""
    high = rig.limits.max_run_s
    return in_range(
        "max_time_s", value, low=0, high=high, unit="s", default=min(120.0, high), why_high=why_high
    )


def load_given(raw: dict[str, Any], name: str, unit: str, test: str) -> list[Problem]:
    """What a tow's or spin's load needs of the fields given: ``name`` or ``weight_kg``,
    not both; a thruster-driven test takes ``name``."""
    load, weight = raw.get(name), raw.get("weight_kg")
    if load is None and weight is None:
        return [(name, None, f"give {name} ({unit}) or weight_kg (kg)")]
    if load is not None and weight is not None:
        return [("weight_kg", weight, f"give {name} or weight_kg, not both")]
    if raw.get("drive", "weight") == "thrusters" and weight is not None:
        return [("weight_kg", weight, f"a thruster-driven {test} takes {name}")]
    return []


def applied_load(
    drive: str, name: str, load: float | None, weight: float | None, g: float, radius_m: float
) -> tuple[float, float | None, dict[str, float] | None]:
    """The signed load the test applies, the weight hung (to the gram; ``None`` when the
    thrusters drive) and what was asked for if that weight changed it: a hung weight gives
    ``weight · g · radius_m`` (a tow's radius is 1), the thrusters the load asked for."""
    if drive != "weight":
        assert load is not None
        return load, None, None
    asked = (name, load) if load is not None else ("weight_kg", weight)
    signed_kg = load / (g * radius_m) if load is not None else weight
    assert signed_kg is not None
    rounded = round(abs(signed_kg) / WEIGHT_RESOLUTION_KG) * WEIGHT_RESOLUTION_KG
    if rounded <= 0:
        raise ParameterError([(asked[0], asked[1], "at least a 1 g weight's worth")])
    hung = round(rounded, 6)
    applied = float(f"{math.copysign(hung * g * radius_m, signed_kg):.{LOAD_DIGITS}g}")
    kept = applied if asked[0] == name else math.copysign(hung, signed_kg)
    value = asked[1]
    changed = value is not None and not math.isclose(value, kept, rel_tol=1e-9, abs_tol=1e-12)
    return applied, hung, ({asked[0]: value} if changed and value is not None else None)


_UNITS = {"force_n": "N", "torque_nm": "N·m", "weight_kg": "kg"}


def adjustment(requested: dict[str, float] | None, mass_kg: float | None, load: str) -> str | None:
    """The sentence telling the operator the requested load was rounded, if it was."""
    if not requested or mass_kg is None:
        return None
    (name, value), *_ = requested.items()
    return (
        f"{name} {value:g} {_UNITS.get(name, '')} asked for; weights hang to the gram, so "
        f"{mass_kg:.3f} kg is hung and the run applies {load}"
    )


@dataclass(frozen=True)
class Progress:
    """What a running procedure reports: 0..1 and a one-line message."""

    fraction: float
    message: str
    state: str = "running"
    extra: dict[str, Any] = field(default_factory=dict)
