"""Whether a stored estimation result can tell K_L from K_Q, read from the document itself.

One drive level fixes only the damping at the speed it ran, K_L + K_Q·|v|: along
(ΔK_L, ΔK_Q) ∝ (|v|, −1) the runs barely change, so K_L and K_Q come out nearly
collinear (|ρ| → 1) and their individual σ say little about what the set decided; a small
model error (a thrust ramp, a lag) moves both along that line far beyond σ. What the set
does fix is the combined damping D(|v|) = K_L + K_Q·|v| at its own speed, |v| being the
speed at which that sum has the least variance: |v| = −ρ·σ_L/σ_Q.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

from estimation.axis.tow_estimate import SEPARABILITY_LIMIT

#: The estimator's warning for a set driven at one force / torque only.
_ONE_LEVEL = re.compile(r"K_L and K_Q are not separable from one (force|torque|drive)")


@dataclass(frozen=True)
class SetSeparability:
    """How well one result document separates K_L from K_Q."""

    rho: float | None  # ρ(K_L, K_Q) of the fit; None when the document has no matrix
    one_level: bool  # the document says its runs had one drive level
    speed: float | None  # |v| where K_L + K_Q·|v| is best fixed (None when not derivable)
    damping: float | None = None  # K_L + K_Q·|v| at that speed

    @property
    def separable(self) -> bool:
        """Neither one drive level nor |ρ(K_L, K_Q)| above the estimator's SEPARABILITY_LIMIT."""
        return not (self.one_level or (self.rho is not None and abs(self.rho) > SEPARABILITY_LIMIT))

    @property
    def drive(self) -> float | None:
        """The steady drive that holds the set's speed, |v|·D(|v|) (N or N·m)."""
        if self.speed is None or self.damping is None:
            return None
        return self.speed * self.damping


def _rho(doc: dict[str, Any]) -> float | None:
    corr = doc.get("correlation") or {}
    names, matrix = corr.get("names") or [], corr.get("matrix") or []
    try:
        i, j = names.index("linear_damping"), names.index("quadratic_damping")
        rho = matrix[i][j]
    except (ValueError, IndexError, TypeError):
        return None
    return float(rho) if rho is not None and math.isfinite(float(rho)) else None


def _fit(doc: dict[str, Any], name: str) -> tuple[float, float]:
    c = doc["coefficients"][name]
    value = float("nan") if c.get("value") is None else float(c["value"])
    std = float("nan") if c.get("std") is None else float(c["std"])
    return value, std


def separability(doc: dict[str, Any]) -> SetSeparability:
    """Read ρ(K_L, K_Q), the one-drive-level warning and the set's speed from a document."""
    rho = _rho(doc)
    one_level = any(_ONE_LEVEL.search(str(w)) for w in doc.get("warnings", []))
    levels = doc.get("drive_levels")  # not written today; honoured if a document carries it
    if isinstance(levels, list) and len(levels) < 2:
        one_level = True
    speed = damping = None
    kl, sl = _fit(doc, "linear_damping")
    kq, sq = _fit(doc, "quadratic_damping")
    if rho is not None and sl > 0 and sq > 0:
        v = -rho * sl / sq
        if math.isfinite(v) and v > 0:
            speed, damping = v, kl + kq * v
    return SetSeparability(rho, one_level, speed, damping)


def damping_at(doc: dict[str, Any], speed: float) -> tuple[float, float]:
    """K_L + K_Q·|v| at ``speed`` from one document, with σ (nan without a correlation).

    σ² = σ_L² + 2|v|ρσ_Lσ_Q + v²σ_Q² from the fit, plus the calibration's share, which
    scales K_L and K_Q together ((σcal_L + |v|·σcal_Q)²); when the run-level bootstrap σ of
    K_L or K_Q exceeds the fit's, the fit's share is widened by the larger ratio.
    """
    kl, sl = _fit(doc, "linear_damping")
    kq, sq = _fit(doc, "quadratic_damping")
    value = kl + kq * speed
    rho = _rho(doc)
    if rho is None or not (math.isfinite(sl) and math.isfinite(sq)):
        return value, float("nan")
    var_fit = sl**2 + 2 * speed * rho * sl * sq + speed**2 * sq**2
    boot = (doc.get("bootstrap") or {}).get("std") or {}
    widen = 1.0
    for name, s in (("linear_damping", sl), ("quadratic_damping", sq)):
        b = boot.get(name)
        if b is not None and s > 0 and b > s:
            widen = max(widen, b / s)
    params = (doc.get("uncertainty") or {}).get("parameters") or {}
    cal_l = (params.get("linear_damping") or {}).get("std_calibration") or 0.0
    cal_q = (params.get("quadratic_damping") or {}).get("std_calibration") or 0.0
    std = math.sqrt(max(var_fit, 0.0) * widen**2 + (cal_l + speed * cal_q) ** 2)
    return value, std
