"""Whether a fitted effect is a physical finding: resolvable by the experiment.

Two rules, each from what the experiment can resolve (not from the drive's size):
- a timing term (release delay) within ``RESOLUTION_SIGMAS`` σ of the release timing (or
  ``DELAY_STEP_FRACTION`` of a sample step when the release is known exactly) is timing;
- any other effect must move the fitted motion by at least ``MATERIAL_NOISE`` × what the data
  cannot resolve (``motion_floor``: position noise, release timing, round-off).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.effects import EFFECTS
from estimation.axis.model import simulate
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import MotionFit
from estimation.stats.acceptance_rules import MATERIAL_NOISE, NUMERICAL_SHARE
from estimation.stats.diagnostics import position_noise

RESOLUTION_SIGMAS = 3.0  # a delay within 3σ of the release timing's resolution is not one
DELAY_STEP_FRACTION = 0.01  # nor one below 1 % of the sample step (release known exactly)


def _effect_force(effect: str, value: float, run: PreparedRun, velocity: np.ndarray) -> float:
    """Largest force/torque the effect exerts over one run's data (N or N·m): the entry's
    own regressor along the fitted motion."""
    accel = np.gradient(velocity, run.t) if velocity.size > 1 else np.zeros_like(velocity)
    return EFFECTS[effect].largest_force(
        value, run.x - run.x[0], velocity, accel, run.weight_equivalent
    )


def below_resolution(effect: str, fit: MotionFit, runs: Sequence[PreparedRun]) -> str | None:
    """Why an effect is too small to be a physical finding, or None.

    - a release delay is a start-time offset; when the release instant itself is only known
      to ±σ_t (host timing), an offset within 3σ_t (or 1 % of a sample step, for a release
      given exactly) is timing, not stiction;
    - any other effect must change the fitted motion by at least the position noise σ
      the fit implies (RMS over the samples of x(θ) − x(θ with the effect at 0),
      ``diagnostics.position_noise``): a term that moves the trajectory by less than the
      instrument's own scatter is not a physical finding, however many samples make it
      significant. Measured against the noise, not against the drive: a damping that is
      1 % of a restoring torque is still plainly visible in a decay's envelope.
    """
    value = fit.value(effect)
    if EFFECTS[effect].role == "timing":
        timing = max((r.t_release_std for r in runs), default=0.0)
        step = min(float(np.median(np.diff(r.t))) for r in runs if r.t.size > 1)
        if abs(value) < max(RESOLUTION_SIGMAS * timing, DELAY_STEP_FRACTION * step):
            return (
                f"{effect} {abs(value) * 1e3:.2g} ms is within the release-timing "
                f"resolution ({RESOLUTION_SIGMAS:g} × {timing * 1e3:.1f} ms, at least "
                f"{DELAY_STEP_FRACTION:.0%} of the {step * 1e3:.0f} ms sample step)"
            )
        return None
    explained = effect_motion_rms(effect, fit, runs)
    floor = motion_floor(fit, runs)
    if explained < MATERIAL_NOISE * floor:
        return (
            f"{effect} not material: it moves the fit by {explained:.3g} RMS, below the "
            f"floor {floor:.3g} (position noise, release timing, round-off)"
        )
    return None


def motion_floor(fit: MotionFit, runs: Sequence[PreparedRun]) -> float:
    """What the data cannot resolve in the motion (m or rad): the largest of the position
    noise σ the fit implies, the motion a release error of RESOLUTION_SIGMAS × its σ
    produces (RMS of v·3σ_t: the release instant is only known that well), and round-off
    (NUMERICAL_SHARE of the travel: noise-free data have no noise to measure against)."""
    v = np.concatenate(
        [u * RESOLUTION_SIGMAS * r.t_release_std for u, r in zip(fit.velocities, runs, strict=True)]
    )
    timing = float(np.sqrt(np.mean(v**2))) if v.size else 0.0
    travel = max((float(np.ptp(r.x)) for r in runs), default=0.0)
    return max(position_noise(fit.residuals, [r.t for r in runs]), timing, NUMERICAL_SHARE * travel)


def effect_motion_rms(effect: str, fit: MotionFit, runs: Sequence[PreparedRun]) -> float:
    """RMS (m or rad) of the change in the fitted motion when ``effect`` is set to 0."""
    values = fit.values.copy()
    values[fit.names.index(effect)] = float(
        np.clip(0.0, EFFECTS[effect].lower, EFFECTS[effect].upper)
    )
    sims = simulate(np.vstack([fit.values, values]), fit.effects, runs)
    diff = np.concatenate([x[0] - x[1] for x, _ in sims])
    diff = diff[np.isfinite(diff)]
    return float(np.sqrt(np.mean(diff**2))) if diff.size else 0.0
