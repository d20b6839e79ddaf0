"""Run data as the estimators see it: arrays plus metadata, no device code."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from estimation.data.window import WindowReport, check_time_step, find_window

Axis = Literal["surge", "yaw"]
AXES: tuple[str, ...] = ("surge", "yaw")
#: The degrees of freedom a linear (``surge``-axis) run may be imported as: the same
#: equation of motion along another straight line (a settling sphere falls in heave).
LINEAR_DOFS: tuple[str, ...] = ("heave", "surge", "sway")
MIN_MOVING_SAMPLES = 5


@dataclass(frozen=True)
class RunData:
    """One tow (surge) or spin (yaw) run.

    ``t`` in s (monotonic), ``position`` in m (surge) or rad (yaw), ``drive`` the applied
    force in N / torque in N·m (a constant for weight-driven runs, or one value per sample).
    ``drive_inertia`` is the known extra inertia of the drive train in axis units (pulley
    J_p/r_p² in kg for surge, drum J_d in kg·m² for yaw); the hung weight's own inertia
    (m_w, or m_w·r_d² for yaw) is added by the estimator when ``hung_mass_kg`` (and for yaw
    ``drum_radius_m``) is given. Samples before ``t_release`` are the at-rest baseline;
    samples after ``t_end`` (end of travel, brake) are ignored. A ``t_release`` before the
    first sample is a record that starts after the release (the body released from rest
    then, already moving when the record begins).
    """

    run_id: str
    axis: Axis
    t: np.ndarray
    position: np.ndarray
    drive: float | np.ndarray
    hung_mass_kg: float | None = None
    drive_inertia: float = 0.0
    drum_radius_m: float | None = None
    t_release: float = 0.0
    t_end: float | None = None
    #: How well the release instant is known (1σ, s): host timing of the brake command.
    #: A fitted release delay within 3× this is not reported as an effect.
    t_release_std: float = 0.0
    #: Thruster-driven runs: K alternative drives, shape (K, len(t)), from thrust curves
    #: drawn within the calibration's uncertainty (None: the drive is known exactly).
    drive_draws: np.ndarray | None = None
    #: How the fitted window was found in a raw recording (``estimation.data.window``); None:
    #: ``t_release``/``t_end`` were given.
    window_found: WindowReport | None = None
    #: Thruster-driven runs: how the thrust's supply-voltage dependence was taken (the
    #: identified law of a multi-voltage calibration, or the rig file's exponent).
    drive_law: str | None = None
    #: The vehicle's own mass (kg; or its displacement, or its dry inertia in kg·m² for yaw)
    #: when known: an identified inertia (m + m_a) below it is flagged as not physical.
    body_inertia: float | None = None
    #: The degree of freedom as imported (a tow's ``heave``, ``surge`` or ``sway``): what
    #: results, reports and warnings call the axis. None: the axis itself.
    dof: str | None = None

    @property
    def dof_name(self) -> str:
        """The axis in the user's words: the imported ``dof``, else ``axis``."""
        return self.dof or self.axis

    def window_report(self) -> WindowReport:
        """The window as fitted: the found one, or one built from the given instants."""
        if self.window_found is not None:
            return self.window_found
        t = np.asarray(self.t)
        after = 0 if self.t_end is None else int(np.count_nonzero(t > self.t_end))
        return WindowReport(
            float(self.t_release),
            "given",
            self.t_end,
            "given" if self.t_end is not None else "last sample",
            int(np.count_nonzero(t <= self.t_release)),
            after,
            0,
            float(t[0]) if t.size else 0.0,
        )

    def declared_extra_inertia(self) -> float:
        """Known inertia that moves with the vehicle (axis units): drive train + hung weight."""
        extra = float(self.drive_inertia)
        if self.hung_mass_kg is not None:
            if self.axis == "surge":
                extra += float(self.hung_mass_kg)
            elif self.drum_radius_m is not None:
                extra += float(self.hung_mass_kg) * float(self.drum_radius_m) ** 2
        return extra

    def hung_mass_declared(self) -> bool:
        """True when the hung weight's inertia is part of the declared model."""
        if self.hung_mass_kg is None:
            return False
        return self.axis == "surge" or self.drum_radius_m is not None

    def window(self) -> np.ndarray:
        """Boolean mask of the usable samples (t ≤ t_end)."""
        if self.t_end is None:
            return np.ones(self.t.shape, dtype=bool)
        return self.t <= self.t_end

    def drive_at_samples(self) -> np.ndarray:
        """Drive as one value per sample (N or N·m)."""
        drive = np.asarray(self.drive, dtype=float)
        if drive.ndim == 0:
            return np.full(self.t.shape, float(drive))
        return drive

    def is_constant_drive(self) -> bool:
        """True for weight-driven runs (scalar drive)."""
        return np.asarray(self.drive).ndim == 0


def field_error(run_id: str, field: str, value: object, allowed: str) -> ValueError:
    """A run's unusable field: the error names the run, field, value and what is allowed."""
    return ValueError(f"run {run_id!r}: {field}: got {value!r}, allowed: {allowed}")


def validate_run(run: RunData) -> None:
    """Raise ValueError naming the field, the value and what is allowed when a run is unusable."""
    rid = run.run_id
    if run.axis not in AXES:
        raise field_error(rid, "axis", run.axis, "'surge' or 'yaw'")
    t = validate_series(rid, run.t, run.position, "position", "finite positions")
    check_time_step(t, "t", f"run {rid!r}")
    drive = np.asarray(run.drive, dtype=float)
    if drive.ndim not in (0, 1) or (drive.ndim == 1 and drive.shape != t.shape):
        raise field_error(rid, "drive", f"shape {drive.shape}", "a scalar or one value per sample")
    if not np.all(np.isfinite(drive)):
        raise field_error(rid, "drive", "NaN/inf", "finite force/torque")
    if not np.any(drive != 0):
        raise field_error(rid, "drive", 0.0, "a non-zero force (N) or torque (N·m)")
    if run.drive_draws is not None:
        draws = np.asarray(run.drive_draws, dtype=float)
        if draws.ndim != 2 or draws.shape[1] != t.size or draws.shape[0] < 2:
            raise field_error(
                rid, "drive_draws", f"shape {draws.shape}", f"(K ≥ 2, {t.size}) or None"
            )
        if not np.all(np.isfinite(draws)):
            raise field_error(rid, "drive_draws", "NaN/inf", "finite forces/torques")
    if run.hung_mass_kg is not None and not run.hung_mass_kg > 0:
        raise field_error(rid, "hung_mass_kg", run.hung_mass_kg, "> 0 kg or None")
    if not (np.isfinite(run.t_release_std) and run.t_release_std >= 0):
        raise field_error(rid, "t_release_std", run.t_release_std, ">= 0 s")
    if not run.drive_inertia >= 0:
        raise field_error(rid, "drive_inertia", run.drive_inertia, ">= 0")
    if run.drum_radius_m is not None and not run.drum_radius_m > 0:
        raise field_error(rid, "drum_radius_m", run.drum_radius_m, "> 0 m or None")
    if t.size and not (np.isfinite(run.t_release) and run.t_release <= t[-1]):
        # before t[0]: a record that starts after the release, the body already moving
        raise field_error(
            rid, "t_release", run.t_release, f"a time ≤ {t[-1]:g} s (the last sample)"
        )
    if run.dof is not None and (run.axis != "surge" or run.dof not in LINEAR_DOFS):
        allowed = ", ".join(LINEAR_DOFS) if run.axis == "surge" else "None (a spin is yaw)"
        raise field_error(rid, "dof", run.dof, allowed)
    if run.body_inertia is not None and not run.body_inertia > 0:
        raise field_error(rid, "body_inertia", run.body_inertia, "> 0 or None")
    moving = np.count_nonzero((t > run.t_release) & run.window())
    if moving < MIN_MOVING_SAMPLES:
        raise field_error(
            rid, "t", f"{moving} samples after release", f">= {MIN_MOVING_SAMPLES} samples"
        )


def validate_runs(runs: Sequence[RunData]) -> str:
    """Validate a set of runs for a joint fit (one axis, one imported dof); returns their
    common axis."""
    axis = validate_run_set(runs, validate_run, "run", "one axis per fit")
    dofs = sorted({run.dof_name for run in runs})
    if len(dofs) != 1:
        raise ValueError(f"runs: dof: got mixed dofs {dofs}, allowed: one dof per fit")
    return axis


def validate_run_set(runs: Sequence, validate_one, what: str, one_axis: str) -> str:
    """Validate each run (``validate_one``), then the set: not empty, one common ``axis``,
    unique ``run_id``s. Returns the axis."""
    if len(runs) == 0:
        raise ValueError(f"runs: got 0 runs, allowed: at least 1 {what}")
    for run in runs:
        validate_one(run)
    axes = sorted({run.axis for run in runs})
    if len(axes) != 1:
        raise ValueError(f"runs: axis: got mixed axes {axes}, allowed: {one_axis}")
    ids = [run.run_id for run in runs]
    if len(set(ids)) != len(ids):
        raise ValueError(f"runs: run_id: got duplicates {ids}, allowed: unique ids")
    return axes[0]


def validate_series(run_id: str, t, values, name: str, finite: str) -> np.ndarray:
    """Check a sampled signal: 1-D like ``t``, finite, ``t`` strictly increasing; returns t."""
    t = np.asarray(t)
    x = np.asarray(values)
    if t.ndim != 1 or x.ndim != 1 or t.shape != x.shape:
        raise field_error(run_id, name, f"shape {x.shape} vs t {t.shape}", "1-D, same length as t")
    if not np.all(np.isfinite(t)):
        raise field_error(run_id, "t", "NaN/inf", "finite sample times")
    if not np.all(np.isfinite(x)):
        raise field_error(run_id, name, "NaN/inf", finite)
    if t.size > 1 and np.any(np.diff(t) <= 0):
        raise field_error(run_id, "t", "non-increasing", "strictly increasing sample times")
    return t


def windowed_run(
    run: RunData,
    *,
    release_coil: np.ndarray | None = None,
    end_switch: np.ndarray | None = None,
    release_known: bool = False,
    end_known: bool = False,
) -> RunData:
    """``run`` with its window found (``find_window``): spikes removed from its samples,
    ``t_release``/``t_end`` set unless ``release_known``/``end_known`` (then the run's own
    are kept and reported as "given"), and the report in ``run.window_found``."""
    drive = np.asarray(run.drive, dtype=float)
    keep, report, release_std = find_window(
        run.t,
        run.position,
        direction=float(np.sign(np.mean(drive))),
        release_coil=release_coil,
        end_switch=end_switch,
        t_release=run.t_release if release_known else None,
        t_end=run.t_end if end_known else None,
    )
    return replace(
        run,
        t=np.asarray(run.t, dtype=float)[keep],
        position=np.asarray(run.position, dtype=float)[keep],
        drive=drive[keep] if drive.ndim else run.drive,
        drive_draws=None if run.drive_draws is None else np.asarray(run.drive_draws)[:, keep],
        t_release=report.t_release,
        t_end=report.t_end,
        t_release_std=run.t_release_std if release_std is None else release_std,
        window_found=report,
    )
