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

What refits is the estimate's own method (``Refit``): the output-error fit by default, a
seed method's regression for its result (``tow_estimate.seed_fit``), so each method's
sensitivity to its drive and release is its own.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import PreparedRun, prepare
from estimation.data.run_arrays import RunData
from estimation.motion.output_error_fit import MotionFit
from estimation.stats.quantization import encoder_step


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


#: The estimate's method on prepared runs, started at ``fit``: the coefficients' values.
Refit = Callable[[list[PreparedRun], MotionFit], np.ndarray]


def output_error_values(prepared: list[PreparedRun], fit: MotionFit) -> np.ndarray:
    """The output-error fit's values with ``fit``'s effects, started at its values."""
    return fit_output_error(
        prepared, fit.effects, start=fit.values, quantization_sigma=False
    ).values


def release_timing(
    runs: Sequence[RunData], fit: MotionFit, refit: Refit = output_error_values
) -> dict[str, float]:
    """σ_rel per parameter: refit with each run's release moved by its ``t_release_std``."""
    prepared = [prepare(r) for r in runs]
    shifts = []
    for i, run in enumerate(runs):
        if not run.t_release_std > 0:
            continue
        moved = list(prepared)
        moved[i] = replace(prepared[i], t_release=prepared[i].t_release + run.t_release_std)
        values = refit(moved, fit)
        if np.all(np.isfinite(values)):
            shifts.append(values - fit.values)
    total = np.sqrt(np.sum(np.square(shifts), axis=0)) if shifts else np.zeros(len(fit.names))
    return {n: float(s) for n, s in zip(fit.names, total, strict=True)}


def drive_uncertainty(
    runs: Sequence[RunData], fit: MotionFit, refit: Refit = output_error_values
) -> DriveUncertainty:
    """Refit ``fit``'s model (same effects, by ``refit``) once per drive draw; σ_cal is the
    spread."""
    std_fit = {n: float(s) for n, s in zip(fit.names, fit.std, strict=True)}
    timing = release_timing(runs, fit, refit)
    drawn = [np.asarray(r.drive_draws) for r in runs if r.drive_draws is not None]
    if not drawn:
        return DriveUncertainty(0, std_fit, dict.fromkeys(fit.names, 0.0), timing)
    count = min(d.shape[0] for d in drawn)
    steps = [encoder_step(np.asarray(r.position)) for r in runs]  # a draw moves no position
    values = []
    for k in range(count):
        alternative = [
            r if r.drive_draws is None else replace(r, drive=r.drive_draws[k], drive_draws=None)
            for r in runs
        ]
        values.append(refit([prepare(r, q) for r, q in zip(alternative, steps, strict=True)], fit))
    spread = np.std(np.array(values), axis=0, ddof=1)
    return DriveUncertainty(
        count, std_fit, {n: float(s) for n, s in zip(fit.names, spread, strict=True)}, timing
    )
