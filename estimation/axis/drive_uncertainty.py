"""The thrust calibration's uncertainty carried into the coefficients.

A thruster-driven run's drive is rebuilt from the calibrated thrust curve, whose
parameters are uncertain. Such runs carry K alternative drives from curves drawn within
the calibration's covariance (``RunData.drive_draws``); refitting the final model once
per draw (from the final values: a few iterations) gives each parameter's calibration
spread σ_cal. Weight-driven runs know their drive: σ_cal = 0.

The release instants are known to ±σ_t per run (``RunData.t_release_std``: host timing of
a recorded release, or how sharply a found release is fixed by the data); refitting with
each run's release moved by its σ_t gives the timing part σ_rel = √Σ(Δθ_run²). The three
are independent: σ_total = √(σ_fit² + σ_cal² + σ_rel²).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.motion.output_error_fit import MotionFit


@dataclass(frozen=True)
class DriveUncertainty:
    """σ_fit, σ_cal and σ_total per fitted parameter (coefficients and effects)."""

    draws: int  # refits done (0: no run carries drive draws)
    std_fit: dict[str, float]
    std_calibration: dict[str, float]
    std_release_timing: dict[str, float] = field(default_factory=dict)

    @property
    def std_total(self) -> dict[str, float]:
        """√(σ_fit² + σ_cal² + σ_rel²) per parameter."""
        return {
            n: float(
                np.sqrt(
                    s**2 + self.std_calibration[n] ** 2 + self.std_release_timing.get(n, 0.0) ** 2
                )
            )
            for n, s in self.std_fit.items()
        }


def release_timing(runs: Sequence[RunData], fit: MotionFit) -> dict[str, float]:
    """σ_rel per parameter: refit with each run's release moved by its ``t_release_std``."""
    prepared = [prepare(r) for r in runs]
    shifts = []
    for i, run in enumerate(runs):
        if not run.t_release_std > 0:
            continue
        moved = list(prepared)
        moved[i] = replace(prepared[i], t_release=prepared[i].t_release + run.t_release_std)
        refit = fit_output_error(moved, fit.effects, start=fit.values, quantization_sigma=False)
        if np.all(np.isfinite(refit.values)):
            shifts.append(refit.values - fit.values)
    total = np.sqrt(np.sum(np.square(shifts), axis=0)) if shifts else np.zeros(len(fit.names))
    return {n: float(s) for n, s in zip(fit.names, total, strict=True)}


def drive_uncertainty(runs: Sequence[RunData], fit: MotionFit) -> DriveUncertainty:
    """Refit ``fit``'s model (same effects) once per drive draw; σ_cal is the spread."""
    std_fit = {n: float(s) for n, s in zip(fit.names, fit.std, strict=True)}
    timing = release_timing(runs, fit)
    drawn = [np.asarray(r.drive_draws) for r in runs if r.drive_draws is not None]
    if not drawn:
        return DriveUncertainty(0, std_fit, dict.fromkeys(fit.names, 0.0), timing)
    count = min(d.shape[0] for d in drawn)
    values = []
    for k in range(count):
        alternative = [
            r if r.drive_draws is None else replace(r, drive=r.drive_draws[k], drive_draws=None)
            for r in runs
        ]
        refit = fit_output_error(
            [prepare(r) for r in alternative],
            fit.effects,
            start=fit.values,
            quantization_sigma=False,
        )
        values.append(refit.values)
    spread = np.std(np.array(values), axis=0, ddof=1)
    return DriveUncertainty(
        count, std_fit, {n: float(s) for n, s in zip(fit.names, spread, strict=True)}, timing
    )
