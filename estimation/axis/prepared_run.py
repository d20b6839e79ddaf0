"""A run as a tow or spin fit reads it: its usable window in arrays, with what the inertia
and the start values need (drive train, weight equivalent, mean drive, encoder step); the
one equation's record of it is ``axis.model.record_of``."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimation.data.run_arrays import RunData
from estimation.motion.terms import STANDARD_GRAVITY
from estimation.stats.quantization import encoder_step

BASELINE_KEPT_S = 0.0  # at-rest samples carry a fixed quantization error: not fitted


@dataclass(frozen=True)
class PreparedRun:
    """The usable part of a run, in arrays the simulators read."""

    run_id: str
    t: np.ndarray
    x: np.ndarray
    drive: np.ndarray  # per sample
    constant_drive: float | None
    t_release: float
    extra_inertia: float
    mean_abs_drive: float
    weight_equivalent: float  # |τ|/g when the hung weight is undeclared, else 0 (drive_inertia)
    t_release_std: float = 0.0  # 1σ uncertainty of the release instant, s
    #: The drive held from the last sample at or before the release until the first kept
    #: sample (per-sample drives; None: ``drive[0]``).
    drive_at_release: float | None = None
    #: The record's quantization step (m or rad; 0: not on a grid), ``estimation.stats.
    #: quantization.encoder_step`` of the whole record, baseline included.
    encoder_step: float = 0.0
    dof: str = "surge"  # the DOF it moved along, as imported (a spin: yaw)


def prepare(run: RunData, step: float | None = None) -> PreparedRun:
    """Cut a run to its usable window and precompute what the simulators need. ``step``:
    the encoder step of ``run.position`` when the caller has it (a re-fit of the same
    positions with another drive or rig constant: ``encoder_step`` is the costliest part)."""
    keep = run.window() & (np.asarray(run.t) > run.t_release - BASELINE_KEPT_S)
    t = np.asarray(run.t, dtype=float)[keep]
    drive = run.drive_at_samples()[keep]
    moving = t > run.t_release
    const = float(np.asarray(run.drive)) if run.is_constant_drive() else None
    mean_abs = float(np.mean(np.abs(drive[moving]))) if moving.any() else 0.0
    x = np.asarray(run.position, dtype=float)[keep]
    return PreparedRun(
        run_id=run.run_id,
        t=t,
        x=x,
        drive=drive,
        constant_drive=const,
        t_release=float(run.t_release),
        extra_inertia=run.declared_extra_inertia(),
        mean_abs_drive=mean_abs,
        weight_equivalent=(
            mean_abs / STANDARD_GRAVITY
            if const is not None and not run.hung_mass_declared()
            else 0.0
        ),
        t_release_std=float(run.t_release_std),
        drive_at_release=_held_at(run, run.t_release),
        encoder_step=encoder_step(np.asarray(run.position)) if step is None else step,
        dof=run.dof_name,
    )


def _held_at(run: RunData, instant: float) -> float | None:
    """The per-sample drive held at ``instant`` (the last sample at or before it)."""
    if run.is_constant_drive():
        return None
    before = np.nonzero(np.asarray(run.t) <= instant)[0]
    return float(run.drive_at_samples()[before[-1]]) if before.size else None
