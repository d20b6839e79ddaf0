"""One row of an uncertainty budget (``estimation.uncertainty.budget``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from estimation.report_numbers import finite_or_none


@dataclass(frozen=True)
class BudgetRow:
    """One source of one coefficient: u in the source's unit, c = ∂θ/∂x, contribution c·u."""

    source: str
    kind: str  # "A" or "B"
    unit: str
    standard_uncertainty: float
    sensitivity: float
    contribution: float  # |c·u|, coefficient unit
    dof: float  # ν_i (inf: taken as exact)
    combined: bool = True
    note: str = ""
    share: float = 0.0  # (c·u)² / u_c², of the combined sources

    def to_json(self) -> dict[str, Any]:
        return {
            "source": self.source,
            "type": self.kind,
            "unit": self.unit,
            "standard_uncertainty": finite_or_none(self.standard_uncertainty),
            "sensitivity": finite_or_none(self.sensitivity),
            "contribution": finite_or_none(self.contribution),
            "dof": None if math.isinf(self.dof) else finite_or_none(self.dof),
            "combined": self.combined,
            "share": finite_or_none(self.share),
            "note": self.note,
        }
