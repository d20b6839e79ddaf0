"""Stored results side by side: per coefficient each result's value ± U and how far it lies
from the first result in standard uncertainties.

U is the budget's expanded uncertainty (GUM, 95 %) where the result has one, else 2σ of the
fit; σ is the budget's combined standard uncertainty where present, else the fit's σ. The
difference of result b from the reference a is ``|a − b| / √(σa² + σb²)`` (dimensionless;
about 2 or more: the two disagree beyond their uncertainties).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from daq.store.run_records import ResultInfo

#: How many results one comparison takes.
MIN_COMPARED, MAX_COMPARED = 2, 12


def parse_ids(text: str) -> list[int]:
    """``"12,13"`` → ``[12, 13]``; a ``ValueError`` naming ``ids``, the value and what is
    allowed for anything else (fewer than two, repeats, not integers)."""
    allowed = f"{MIN_COMPARED} … {MAX_COMPARED} distinct result ids separated by commas, e.g. 12,13"
    parts = [p.strip() for p in text.split(",") if p.strip()]
    if not all(p.isdigit() for p in parts):
        raise ValueError(f"ids: {text!r} is not allowed; give {allowed}")
    ids = [int(p) for p in parts]
    if not MIN_COMPARED <= len(ids) <= MAX_COMPARED or len(set(ids)) != len(ids):
        raise ValueError(f"ids: {text!r} is not allowed; give {allowed}")
    return ids


def _finite(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def coefficient_cell(data: dict[str, Any], name: str) -> dict[str, Any] | None:
    """One result's ``{value, sigma, U, U_from}`` for coefficient ``name`` (None if absent):
    ``U_from`` is ``budget`` or ``2σ``."""
    fitted = (data.get("coefficients") or {}).get(name)
    if not isinstance(fitted, dict):
        return None
    budget = ((data.get("budget") or {}).get("coefficients") or {}).get(name) or {}
    expanded = _finite(budget.get("expanded_uncertainty"))
    combined = _finite(budget.get("combined_standard_uncertainty"))
    std = _finite(fitted.get("std"))
    if expanded is not None:
        return {"value": _finite(fitted.get("value")), "sigma": combined if combined is not None
                else std, "U": expanded, "U_from": "budget"}  # fmt: skip
    return {
        "value": _finite(fitted.get("value")),
        "sigma": std,
        "U": None if std is None else 2 * std,
        "U_from": "2σ",
    }


def difference_in_sigma(a: dict[str, Any] | None, b: dict[str, Any] | None) -> float | None:
    """``|a − b| / √(σa² + σb²)``, or None where a value or σ is missing or both σ are 0."""
    if a is None or b is None or None in (a["value"], b["value"], a["sigma"], b["sigma"]):
        return None
    scale = math.hypot(a["sigma"], b["sigma"])
    return abs(a["value"] - b["value"]) / scale if scale > 0 else None


def compare_results(found: Sequence[ResultInfo]) -> dict[str, Any]:
    """The comparison document of ``GET /api/results/compare``: the results (id, kind,
    created_at, run_ids, axis, method) and one row per coefficient any of them has, each
    with a cell per result and ``difference_sigma`` of each result from the first."""
    names: list[str] = []
    for r in found:
        names += [n for n in (r.data.get("coefficients") or {}) if n not in names]
    rows = []
    for name in names:
        cells = [coefficient_cell(r.data, name) for r in found]
        unit = next(
            (u for r in found if (u := (r.data.get("units") or {}).get(name)) is not None), None
        )
        rows.append({
            "coefficient": name,
            "unit": unit,
            "cells": cells,
            "difference_sigma": [None, *(difference_in_sigma(cells[0], c) for c in cells[1:])],
        })  # fmt: skip
    return {
        "results": [
            {
                "id": r.id,
                "kind": r.kind,
                "created_at": r.to_json()["created_at"],
                "run_ids": list(r.run_ids),
                "axis": r.data.get("axis"),
                "method": r.data.get("method"),
            }
            for r in found
        ],
        "reference": found[0].id,
        "coefficients": rows,
    }
