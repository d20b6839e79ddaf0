"""Numbers for JSON documents, which have no NaN or infinity."""

from __future__ import annotations

import math


def finite_or_none(x: float | None) -> float | None:
    """``x`` as a float; None when it is None, NaN or infinite (unread, not identified)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None
