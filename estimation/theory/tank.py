"""How far the tank is from the unbounded fluid the added-mass theory assumes: the
blockage ratio.

ITTC 7.5-02-02-01 (Resistance Test, 2011) defines the blockage parameter

    m = A_X / A,

A_X the model's largest cross-section and A the tank's wetted cross-section (width × water
depth for a rectangular tank), and corrects speed and resistance for it. We report m and
flag it above ``DEFAULT_LIMIT`` = 1 %: our choice, not an ITTC number (the procedure gives
the corrections, not a limit). Above it, walls and the free surface raise the added mass
and the damping enough that a comparison with unbounded-fluid theory needs a correction
(image bodies or a BEM with the tank's walls); we do not compute that correction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Blockage ratio above which a result is flagged (our choice; module docstring).
DEFAULT_LIMIT = 0.01


class TankError(ValueError):
    """A tank or body size that gives no ratio (one line: field, value, allowed)."""

    def __init__(self, field_name: str, value: object, allowed: str) -> None:
        self.field, self.value, self.allowed = field_name, value, allowed
        super().__init__(f"{field_name}: got {value!r}, allowed: {allowed}")


@dataclass(frozen=True)
class Blockage:
    """m = A_X / A with its inputs; ``exceeds`` when m > ``limit``; ``message`` one line."""

    frontal_area_m2: float
    tank_width_m: float
    water_depth_m: float
    ratio: float
    limit: float
    exceeds: bool
    message: str

    def to_json(self) -> dict:
        return {
            "frontal_area_m2": self.frontal_area_m2,
            "tank_width_m": self.tank_width_m,
            "water_depth_m": self.water_depth_m,
            "tank_section_m2": self.tank_width_m * self.water_depth_m,
            "ratio": self.ratio,
            "limit": self.limit,
            "exceeds": self.exceeds,
            "message": self.message,
        }


def _positive(field_name: str, value: float, limit: float, unit: str = "m") -> float:
    if (
        not isinstance(value, (int, float))
        or isinstance(value, bool)
        or not math.isfinite(value)
        or not 0 < value <= limit
    ):
        raise TankError(field_name, value, f"0 < value ≤ {limit:g} {unit}".rstrip())
    return float(value)


def blockage(
    frontal_area_m2: float,
    tank_width_m: float,
    water_depth_m: float,
    limit: float = DEFAULT_LIMIT,
) -> Blockage:
    """m = A_X / (B_tank · h) (ITTC 7.5-02-02-01), flagged when above ``limit``."""
    area = _positive("frontal_area_m2", frontal_area_m2, 1e4, "m²")
    width = _positive("tank_width_m", tank_width_m, 1e3)
    depth = _positive("water_depth_m", water_depth_m, 1e3)
    limit = _positive("limit", limit, 1.0, "")
    section = width * depth
    if area >= section:
        raise TankError("frontal_area_m2", frontal_area_m2, f"< the tank's section {section:g} m²")
    ratio = area / section
    exceeds = ratio > limit
    if exceeds:
        message = (
            f"blockage m = A_X/A = {ratio:.3g} ({100 * ratio:.2g} %) is above {100 * limit:g} %: "
            "walls and free surface raise added mass and damping, so the tank's values are "
            "likely above the unbounded-fluid prediction"
        )
    else:
        message = (
            f"blockage m = A_X/A = {ratio:.3g} ({100 * ratio:.2g} %), within {100 * limit:g} %"
        )
    return Blockage(area, width, depth, ratio, limit, exceeds, message)
