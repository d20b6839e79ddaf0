"""Measured against predicted added mass: the ratio, whether it lies in a stated band and,
when not, what usually causes it.

Why the default band is 0.5 … 2 (a judgement, not a standard): the prediction idealises
the hull as a primitive in an unbounded ideal fluid. A real vehicle's appendages
(thrusters, fins, frames, entrained water in free-flooding spaces) and the tank's walls and
free surface move the true added mass by tens of per cent, rarely by a factor of two;
potential-flow added mass of a body of the right size and shape is otherwise a good
estimate of what an accelerating body carries with it. A ratio beyond a factor of two
either way therefore says that something other than the water around the hull is in the
number (or the hull is described wrongly), not that the theory is a little off. Callers
with better knowledge of their vehicle pass their own band.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: measured / predicted added mass accepted without a flag (module docstring).
DEFAULT_BAND = (0.5, 2.0)

#: What usually puts too much inertia into a tow or spin test's fitted m + m_a.
CAUSES_HIGH = (
    "drive-train inertia (the pulley or spin drum, I/r², accelerates with the vehicle)",
    "hung weight (the falling mass m_w is accelerated by the same tow line: "
    "it adds m_w to the fitted m + m_a unless the model subtracts it)",
    "carriage mass and friction (the carriage moves with the vehicle; "
    "Coulomb friction a model lacks is absorbed by the other terms)",
    "blockage (tank walls, bottom and free surface raise the added mass; "
    "tens of per cent only when the body is large against the tank)",
    "a hull description that misses appendages or water carried in free-flooding spaces",
)
#: What usually makes the measured added mass too small.
CAUSES_LOW = (
    "rig masses subtracted twice (the hung weight or the carriage taken off the fitted total "
    "and again from the body mass)",
    "a body mass or inertia that is too large (the added mass is the fitted total minus it)",
    "a fit that moved inertia into the damping terms (short or noisy transients)",
    "a hull primitive much larger than the vehicle",
)


class CompareError(ValueError):
    """Inputs that cannot be compared (one line: field, value, allowed)."""

    def __init__(self, field_name: str, value: object, allowed: str) -> None:
        self.field, self.value, self.allowed = field_name, value, allowed
        super().__init__(f"{field_name}: got {value!r}, allowed: {allowed}")


@dataclass(frozen=True)
class AddedMassVerdict:
    """``ratio`` = measured / predicted; ``plausible`` when it lies within ``band``;
    ``excess`` = measured − predicted (kg or kg·m², as given); ``message`` one paragraph
    for a report, ``causes`` the usual suspects when it lies outside."""

    measured: float
    predicted: float
    ratio: float
    band: tuple[float, float]
    plausible: bool
    excess: float
    message: str
    causes: tuple[str, ...]

    def to_json(self) -> dict:
        return {
            "measured": self.measured,
            "predicted": self.predicted,
            "ratio": self.ratio,
            "band": list(self.band),
            "plausible": self.plausible,
            "excess": self.excess,
            "message": self.message,
            "causes": list(self.causes),
        }


def _number(field_name: str, value: object) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise CompareError(field_name, value, "a finite number")
    return float(value)


def compare_added_mass(
    measured_kg: float, predicted_kg: float, band: tuple[float, float] = DEFAULT_BAND
) -> AddedMassVerdict:
    """Judge a measured added mass (or added moment of inertia, in the same unit as the
    prediction) against theory: ratio r = measured / predicted, plausible when
    band[0] ≤ r ≤ band[1] (default 0.5 … 2, why in the module docstring)."""
    measured = _number("measured_kg", measured_kg)
    predicted = _number("predicted_kg", predicted_kg)
    if predicted <= 0:
        raise CompareError("predicted_kg", predicted_kg, "> 0 (a DOF the theory predicts)")
    low, high = (_number("band", b) for b in band)
    if not 0 < low < 1 < high:
        raise CompareError("band", band, "(low, high) with 0 < low < 1 < high")
    ratio = measured / predicted
    plausible = low <= ratio <= high
    if plausible:
        message = (
            f"measured {measured:.4g} is {ratio:.2g} × the predicted {predicted:.4g}: "
            f"within {low:g} … {high:g}, plausible for the hull described"
        )
        causes: tuple[str, ...] = ()
    elif ratio > high:
        causes = CAUSES_HIGH
        message = (
            f"measured {measured:.4g} is {ratio:.3g} × the predicted {predicted:.4g} "
            f"(above {high:g}): {measured - predicted:.4g} more than the water around this "
            "hull can carry. Usual causes: " + "; ".join(causes)
        )
    else:
        causes = CAUSES_LOW
        message = (
            f"measured {measured:.4g} is {ratio:.3g} × the predicted {predicted:.4g} "
            f"(below {low:g}). Usual causes: " + "; ".join(causes)
        )
    return AddedMassVerdict(
        measured=measured,
        predicted=predicted,
        ratio=ratio,
        band=(low, high),
        plausible=plausible,
        excess=measured - predicted,
        message=message,
        causes=causes,
    )
