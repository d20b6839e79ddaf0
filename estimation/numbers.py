"""Numbers for JSON documents, which have no NaN or infinity."""

from __future__ import annotations

import math
from collections.abc import Mapping


def finite_or_none(x: float | None) -> float | None:
    """``x`` as a float; None when it is None, NaN or infinite (unread, not identified)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def finite_values(values: Mapping[str, float | None]) -> dict[str, float | None]:
    """Each value of ``values`` by :func:`finite_or_none` (a per-run or per-name table)."""
    return {k: finite_or_none(v) for k, v in values.items()}
