"""One row of an uncertainty budget (``estimation.uncertainty.budget``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
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


def repeatability_row(unit: str, s: float, n: int) -> BudgetRow:
    """The Type A row of N repeat campaigns: u = s/√N (``s`` already divided), ν = N − 1."""
    return BudgetRow(f"repeatability ({n} repeat campaigns, s/√N)", "A", unit, s, 1.0, 0.0, n - 1)


def counted_once(rows: Sequence[BudgetRow]) -> list[BudgetRow]:
    """Type A rows that estimate the same random error (the fit's σ, the quantization, a
    bootstrap, the repeatability): the largest finite one is combined, each other listed as
    overlapping it, not combined (docs/uncertainty.md)."""
    finite = [r for r in rows if math.isfinite(r.standard_uncertainty)]
    largest = max(finite, key=lambda r: r.standard_uncertainty) if finite else None
    overlaps = "overlaps " + (largest.source if largest else "—") + ": not combined"
    return [
        replace(
            r,
            contribution=abs(r.sensitivity * r.standard_uncertainty),
            combined=True,
            note=r.note or "the random error, counted once",
        )
        if r is largest
        else replace(r, contribution=0.0, combined=False, note=overlaps)
        for r in rows
    ]
