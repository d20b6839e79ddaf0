"""Numbers for JSON documents, which have no NaN or infinity, and a value with its σ and unit."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any


def finite_or_none(x: float | None) -> float | None:
    """``x`` as a float; None when it is None, NaN or infinite (unread, not identified)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def finite_values(values: Mapping[str, float | None]) -> dict[str, float | None]:
    """Each value of ``values`` by :func:`finite_or_none` (a per-run or per-name table)."""
    return {k: finite_or_none(v) for k, v in values.items()}


@dataclass(frozen=True)
class Coefficient:
    """A value with its σ (None: not identified by the data), in SI units."""

    value: float
    std: float | None
    unit: str

    def to_json(self) -> dict[str, Any]:
        """{value, std, unit}; a σ that is not known is null."""
        return {
            "value": finite_or_none(self.value),
            "std": finite_or_none(self.std),
            "unit": self.unit,
        }


@dataclass(frozen=True)
class CoefficientWithU(Coefficient):
    """A value ± σ that carries its own expanded uncertainty (a seed method's row, which has
    no budget): U at 95 % (NaN without a σ), its coverage factor k = t_0.975(ν) and ν."""

    expanded: float
    k: float
    dof: float

    def to_json(self) -> dict[str, Any]:
        """{value, std, unit, U, k, nu} (ν null when infinite; U null without a σ)."""
        nu = None if math.isinf(self.dof) else finite_or_none(self.dof)
        return super().to_json() | {
            "U": finite_or_none(self.expanded),
            "k": finite_or_none(self.k),
            "nu": nu,
        }
