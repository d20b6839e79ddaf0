"""The drive of a thruster-driven run, rebuilt from what the controller applied, and the
draws that carry the calibration's uncertainty into the coefficients.

``steps`` are the outputs the controller confirmed (instant, fraction per thruster), or a
ramp modelled by the device side for runs recorded before those were stored. Each step is
held until the next; each thruster's thrust is the calibration's F(output) — or, with a
thrust law identified from calibrations at several voltages, F(output, V) at each instant's
supply voltage — scaled by (V / V_cal(output))^q when only one voltage was calibrated and
the rig file gives q; the sum (tow) or signed moment (spin) follows the outputs with a
first-order lag. The estimator holds each sample's drive until the next sample, so each
value is the mean drive over its sample interval (built on a 1 ms grid).
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass, replace

import numpy as np

from estimation.thrust.curve import PARAMETER_LOWER, PARAMETER_UPPER, CalibratedThrust, ThrustCurve
from estimation.thrust.law import ThrustLaw

DRIVE_GRID_S = 0.001
#: Thrust curves drawn per thruster-driven run to carry the calibration's uncertainty.
DRIVE_DRAWS = 30
DRIVE_DRAW_SEED = 20261121

Steps = list[tuple[float, list[float]]]


@dataclass(frozen=True)
class ThrustLayout:
    """How thruster forces make the drive: per-thruster sign, arm (m; 1 for a force), the
    thrust's first-order time constant (s) and the rig file's voltage exponent q."""

    signs: list[float]
    arm: float
    time_constant_s: float = 0.0
    voltage_exponent: float = 0.0


@dataclass(frozen=True)
class RebuiltDrive:
    """The drive per sample, ``DRIVE_DRAWS`` draws of it, and which voltage law was used."""

    drive: np.ndarray
    draws: np.ndarray
    law: str


def drive_from_steps(
    curve: ThrustCurve | CalibratedThrust | ThrustLaw,
    layout: ThrustLayout,
    t: np.ndarray,
    steps: Steps,
    volts: np.ndarray | None = None,
) -> np.ndarray:
    """Drive (force N, or torque N·m) per sample time ``t`` from the held ``steps``."""
    t = np.asarray(t, dtype=float)
    if t.size == 0:
        return np.zeros(0)
    n = len(layout.signs)
    if any(len(fractions) != n for _, fractions in steps):
        raise ValueError(f"thrust steps: one output per thruster ({n}) needed in every step")
    end = float(t[-1]) + (float(np.median(np.diff(t))) if t.size > 1 else 0.1)
    grid = np.arange(float(t[0]), end + DRIVE_GRID_S, DRIVE_GRID_S)
    step_times = np.array([instant for instant, _ in steps], dtype=float)
    values = np.array([fractions for _, fractions in steps], dtype=float).reshape(-1, n)
    index = np.searchsorted(step_times, grid, side="right") - 1
    outputs = np.where(index[:, None] >= 0, values[np.clip(index, 0, None)], 0.0).T
    supply = supply_on_grid(volts, t, grid)
    force = np.zeros_like(grid)
    for sign, output in zip(layout.signs, outputs, strict=True):
        if isinstance(curve, ThrustLaw):  # identified F(command, V)
            thrust = curve.force(output, supply)
        else:
            thrust = curve.force(output)
        if supply is not None and isinstance(curve, CalibratedThrust):
            thrust = thrust * curve.supply_factor(output, supply, layout.voltage_exponent)
        force += sign * thrust * layout.arm
    if layout.time_constant_s > 0:
        from scipy.signal import lfilter

        alpha = 1.0 - np.exp(-DRIVE_GRID_S / layout.time_constant_s)
        force = lfilter([alpha], [1.0, alpha - 1.0], force)
    # Mean over each sample interval [t_k, t_k+1) (the last one: one median interval).
    edges = np.searchsorted(grid, np.concatenate([t, [end]]))
    total = np.concatenate([[0.0], np.cumsum(force)])
    counts = np.maximum(np.diff(edges), 1)
    return (total[edges[1:]] - total[edges[:-1]]) / counts


def supply_on_grid(volts: np.ndarray | None, t: np.ndarray, grid: np.ndarray) -> np.ndarray | None:
    """The run's supply voltage on the drive grid: a 3-sample running mean (the reading's
    noise) interpolated between samples; None when not recorded."""
    if volts is None or volts.size != t.size or not np.all(np.isfinite(volts)) or t.size < 3:
        return None
    smooth = np.convolve(volts, np.ones(3) / 3, mode="same")
    smooth[0], smooth[-1] = volts[:2].mean(), volts[-2:].mean()
    return np.interp(grid, t, smooth)


def _run_rng(run_id: str, stream: int = 0) -> np.random.Generator:
    """Draws fixed per run id; independent streams for independent error sources."""
    return np.random.default_rng([DRIVE_DRAW_SEED, zlib.crc32(run_id.encode()), stream])


def lack_of_fit_factors(curve: ThrustCurve, params: dict, run_id: str, count: int) -> np.ndarray:
    """Per draw, a factor 1 + δ on the run's whole drive with δ ~ N(0, RMSE / |F|): the
    curve is trusted only to its fit RMSE at the run's thrust F per thruster (a power law
    does not follow real thrusters exactly, and the parameter covariance does not carry
    that). Independent between runs (their commands differ), fixed per run id."""
    force = abs(float(params.get("force_per_thruster_n") or 0.0))
    if not force > 0:
        return np.ones(count)
    return 1.0 + _run_rng(run_id).normal(0.0, curve.rmse_n / force, count)


def curve_draws(curve: ThrustCurve, count: int, seed: int = DRIVE_DRAW_SEED) -> list[ThrustCurve]:
    """``count`` thrust curves with parameters drawn from N(values, cov) of the calibration
    fit (cov from its σ and correlation), kept inside the fit's own bounds; fixed seed."""
    std = np.asarray(curve.std, dtype=float)
    cov = np.outer(std, std) * np.asarray(curve.correlation, dtype=float)
    values = np.random.default_rng(seed).multivariate_normal(
        curve.values, cov, size=count, method="eigh"
    )
    return [replace(curve, values=np.clip(v, PARAMETER_LOWER, PARAMETER_UPPER)) for v in values]


def rebuild_drive(
    law: ThrustLaw | None,
    measured: CalibratedThrust,
    layout: ThrustLayout,
    t: np.ndarray,
    steps: Steps,
    volts: np.ndarray | None,
    run_id: str,
    params: dict,
) -> RebuiltDrive:
    """The run's drive with its draws: through an identified thrust law when there is one
    (σ: its interpolation between voltages), else through the measured calibration with
    the rig file's voltage exponent (σ: curves drawn from the fit's covariance); both times
    the calibration's lack of fit at the run's thrust on top."""
    curve = measured.curve
    if law is not None and law.identified:
        mean_v = law.reference_voltage if volts is None else float(np.mean(volts))
        used = f"{law.voltage_law(mean_v)} (mean supply {mean_v:.3g} V)"
        if volts is None:
            used += ": not recorded, the calibration's highest voltage taken"
        drive = drive_from_steps(law, layout, t, steps, volts)
        # Interpolation between voltages is common to the run.
        factors = 1.0 + _run_rng(run_id, 1).normal(0.0, law.interpolation_error, DRIVE_DRAWS)
        draws = factors[:, None] * drive[None, :]
    else:
        q = layout.voltage_exponent
        used = (
            f"rig file: thrust ∝ V^{q:g} (thrusters.voltage_exponent)"
            if q and volts is not None
            else "no supply-voltage correction"
        )
        drive = drive_from_steps(measured, layout, t, steps, volts)
        draws = np.array(
            [
                drive_from_steps(measured.with_curve(c), layout, t, steps, volts)
                for c in curve_draws(curve, DRIVE_DRAWS)
            ]
        )
    draws = draws * lack_of_fit_factors(curve, params, run_id, DRIVE_DRAWS)[:, None]
    return RebuiltDrive(drive, draws, used)
