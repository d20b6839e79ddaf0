"""The thrust calibration's uncertainty carried into the coefficients.

A thruster-driven run's drive is rebuilt from the calibrated thrust curve, whose
parameters are uncertain. Such runs carry K alternative drives from curves drawn within
the calibration's covariance (``RunData.drive_draws``); refitting the final model once
per draw (from the final values: a few iterations) gives each parameter's calibration
spread σ_cal. The fit's own σ (noise) and σ_cal are independent:
σ_total = √(σ_fit² + σ_cal²). Weight-driven runs know their drive: σ_cal = 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from estimation.model import prepare
from estimation.output_error import FitResult, fit_output_error
from estimation.runs import RunData


@dataclass(frozen=True)
class DriveUncertainty:
    """σ_fit, σ_cal and σ_total per fitted parameter (coefficients and effects)."""

    draws: int  # refits done (0: no run carries drive draws)
    std_fit: dict[str, float]
    std_calibration: dict[str, float]

    @property
    def std_total(self) -> dict[str, float]:
        """√(σ_fit² + σ_cal²) per parameter."""
        return {n: float(np.hypot(s, self.std_calibration[n])) for n, s in self.std_fit.items()}


def drive_uncertainty(runs: Sequence[RunData], fit: FitResult) -> DriveUncertainty:
    """Refit ``fit``'s model (same effects) once per drive draw; σ_cal is the spread."""
    std_fit = {n: float(s) for n, s in zip(fit.names, fit.std, strict=True)}
    drawn = [np.asarray(r.drive_draws) for r in runs if r.drive_draws is not None]
    if not drawn:
        return DriveUncertainty(0, std_fit, dict.fromkeys(fit.names, 0.0))
    count = min(d.shape[0] for d in drawn)
    values = []
    for k in range(count):
        alternative = [
            r if r.drive_draws is None else replace(r, drive=r.drive_draws[k], drive_draws=None)
            for r in runs
        ]
        refit = fit_output_error([prepare(r) for r in alternative], fit.effects, start=fit.values)
        values.append(refit.values)
    spread = np.std(np.array(values), axis=0, ddof=1)
    return DriveUncertainty(
        count, std_fit, {n: float(s) for n, s in zip(fit.names, spread, strict=True)}
    )
