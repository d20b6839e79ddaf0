"""One coefficient compared between a weight-driven and a thruster-driven estimation result
(values ± σ_total, difference, z = Δ / √(σ₁² + σ₂²) and its verdict), and the common factor
k = thruster/weight fitted across the coefficients (weighted mean, χ² test of one factor):
what ``estimation.axis.drive_crosscheck`` diagnoses from."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.motion.terms import units_of
from estimation.report_numbers import finite_or_none

COEFFICIENTS: tuple[str, ...] = ("inertia", "linear_damping", "quadratic_damping")
DAMPING = ("linear_damping", "quadratic_damping")
COMBINED = "damping_at_speed"
LABELS = {
    "inertia": "inertia",
    "linear_damping": "K_L",
    "quadratic_damping": "K_Q",
    COMBINED: "K_L + K_Q·|v|",
}
UNITS = {
    axis: {**units_of(axis), COMBINED: units_of(axis)["linear_damping"]}
    for axis in ("surge", "yaw")
}
SPEED_UNITS = {axis: units["velocity"] for axis, units in UNITS.items()}
#: Two sets that both cannot separate K_L from K_Q are compared on their damping only when
#: their speeds differ by less than this share (each fixes D(|v|) at its own speed only).
SAME_SPEED = 0.25
AGREE_Z = 2.0
DISAGREE_Z = 3.0
#: χ² p-value below which the ratios are not one common factor.
FACTOR_P_MIN = 0.01
#: |k − 1| / σ_k above which the common factor is a finding.
FACTOR_SIGMAS = 3.0
#: Ratio scatter about k, as a share of |k − 1|, below which k carries the disagreement.
DOMINANT_SHARE = 0.25


def verdict(z: float) -> str:
    """``agree`` (|z| < 2), ``marginal`` (2–3) or ``disagree`` (≥ 3); ``unknown`` without σ."""
    if not math.isfinite(z):
        return "unknown"
    return "agree" if abs(z) < AGREE_Z else "marginal" if abs(z) < DISAGREE_Z else "disagree"


@dataclass(frozen=True)
class Comparison:
    """One coefficient from both sets: values ± σ_total, difference and z."""

    name: str
    weight: float
    weight_std: float
    thruster: float
    thruster_std: float
    undecided: str | None = None  # why the sets cannot decide it (no verdict then)
    speed: float | None = None  # |v| of a damping_at_speed comparison

    @property
    def decided(self) -> bool:
        return self.undecided is None

    @property
    def verdict(self) -> str:
        """``undecided`` when the sets cannot decide it, else ``verdict(z)``."""
        return verdict(self.z) if self.decided else "undecided"

    def label(self, axis: str) -> str:
        """``K_L`` etc.; the combined damping with its speed."""
        if self.speed is None:
            return LABELS[self.name]
        return f"{LABELS[self.name]} at |v| = {self.speed:.3g} {SPEED_UNITS[axis]}"

    @property
    def difference(self) -> float:
        """thruster − weight."""
        return self.thruster - self.weight

    @property
    def z(self) -> float:
        """Δ / √(σ_w² + σ_t²) (nan when both σ are 0 or unknown)."""
        s = math.hypot(self.weight_std, self.thruster_std)
        return self.difference / s if s > 0 else float("nan")

    def to_json(self, axis: str) -> dict[str, Any]:
        """The comparison as the API gives it; ``label`` is the one spelling the page and the
        report both show (``label(axis)``)."""
        doc: dict[str, Any] = {
            "label": self.label(axis),
            "weight": {
                "value": finite_or_none(self.weight),
                "std": finite_or_none(self.weight_std),
            },
            "thruster": {
                "value": finite_or_none(self.thruster),
                "std": finite_or_none(self.thruster_std),
            },
            "difference": finite_or_none(self.difference),
            "z": finite_or_none(self.z),
            "verdict": self.verdict,
        }
        if self.speed is not None:
            doc["speed"] = finite_or_none(self.speed)
        if self.undecided is not None:
            doc["reason"] = self.undecided
        return doc


@dataclass(frozen=True)
class CommonFactor:
    """The thruster/weight ratios of the coefficients as one factor k ± σ_k (χ² test)."""

    k: float
    std: float
    chi2: float
    dof: int
    p_value: float
    used: tuple[str, ...]
    spread: float = 0.0  # largest |ratio − k| over the ratios used

    @property
    def thrust_factor(self) -> float:
        """Delivered / calibrated thrust, 1/k (the coefficients scale with the drive
        the estimator was told, not the one the vehicle felt)."""
        return 1.0 / self.k

    @property
    def thrust_factor_std(self) -> float:
        return self.std / self.k**2

    @property
    def consistent(self) -> bool:
        """The ratios agree with one factor (χ² p ≥ 0.01; always true for one ratio)."""
        return self.dof == 0 or self.p_value >= FACTOR_P_MIN

    @property
    def dominant(self) -> bool:
        """The common factor carries the bulk of the disagreement: the ratios scatter about
        k by less than a quarter of |k − 1| (even when χ² says they scatter beyond σ)."""
        return self.spread < DOMINANT_SHARE * abs(self.k - 1.0)

    @property
    def significant(self) -> bool:
        """k differs from 1 by more than 3σ_k."""
        return self.std > 0 and abs(self.k - 1.0) > FACTOR_SIGMAS * self.std

    def to_json(self) -> dict[str, Any]:
        return {
            "k": finite_or_none(self.k),
            "std": finite_or_none(self.std),
            "thrust_factor": finite_or_none(self.thrust_factor),
            "thrust_factor_std": finite_or_none(self.thrust_factor_std),
            "chi2": finite_or_none(self.chi2),
            "dof": self.dof,
            "p_value": finite_or_none(self.p_value),
            "coefficients": list(self.used),
            "spread": finite_or_none(self.spread),
            "consistent": self.consistent,
            "dominant": self.dominant,
            "significant": self.significant,
        }


def common_factor(comparisons: list[Comparison]) -> CommonFactor | None:
    """Weighted mean of thruster/weight over the decided coefficients the weight runs
    resolve (|value| > 2σ); None when fewer than one ratio is usable."""
    ratios, sigmas, used = [], [], []
    for c in comparisons:
        if not c.decided:
            continue
        if not (c.weight > 0 and c.weight > 2 * c.weight_std and np.isfinite(c.thruster)):
            continue
        r = c.thruster / c.weight
        s = math.hypot(c.thruster_std / c.weight, r * c.weight_std / c.weight)
        if s > 0 and math.isfinite(s):
            ratios.append(r)
            sigmas.append(s)
            used.append(c.name)
    if not ratios:
        return None
    from scipy.special import chdtrc  # here: the service imports this module (its UNITS)

    w = 1.0 / np.square(sigmas)
    k = float(np.sum(w * ratios) / np.sum(w))
    stat = float(np.sum(w * (np.array(ratios) - k) ** 2))
    dof = len(ratios) - 1
    p = float(chdtrc(dof, stat)) if dof > 0 else 1.0  # χ² survival (scipy.stats.chi2.sf)
    # The calibration's share of σ is common to all ratios (one drive scale): averaging does
    # not shrink it, so σ_k is never taken below the best single ratio's σ.
    std = max(float(1.0 / math.sqrt(np.sum(w))), float(min(sigmas)))
    spread = float(np.max(np.abs(np.array(ratios) - k)))
    return CommonFactor(k, std, stat, dof, p, tuple(used), spread)
