"""The thesis's three ways to read a free decay (seed 002 §3.3), each giving α and β with σ.

Linearised moment balance J·φ̈ + c·φ̇ + k·φ = 0 with J = J_known + α·l², c = β·l² + b:
decay rate K = c/(2J), damped frequency ω with ω² + K² = k/J, hence

    J = k/(ω² + K²),  α = (J − J_known)/l²,  β = (2·K·J − b)/l².

- ``damped_fit`` (the thesis's lsqcurvefit, its best): φ = C·e^{−Kτ}·sin(ωτ + θ) + offset on
  the whole record after release, τ = t − t₀;
- ``log_decrement`` (the "component" method): extrema of both signs, each refined by a
  parabola through 3 samples; ln|peak| linear in t gives K, the extremum spacing π/ω;
- ``equation_error``: φ̈ = θ₁·|φ̇|·φ̇ + θ₂·φ̇ + θ₃·sin φ on Savitzky–Golay derivatives,
  J = −k/θ₃, c = −θ₂·J, γ = −θ₁·J/l³ (and the linear-only variant without θ₁).
σ everywhere by the delta method from the fit's or regression's covariance, and every
row's coefficient carries U = k·σ at 95 % (``CoefficientWithU``), k = t_0.975(ν) of the
budget (``uncertainty.budget.coverage_factor``). The covariance of ``damped_fit`` and
``equation_error`` is ``stats.serial.serial_covariance`` (the larger of the white and the
AR(1)-prewhitened Newey–West σ; ν = n_eff − p, n_eff = n·(1 − r₁)/(1 + r₁)): their residual
is serially correlated (a model that misses sin φ or a dry friction leaves a smooth residual;
the Savitzky–Golay derivatives of ``equation_error`` correlate it over a window), and
counting its samples as independent made σ too small. ``log_decrement`` regresses one point
per extremum (each half a period apart): white σ, ν = extrema − 2. A pendulum declares no
tolerance (its geometry is taken as exact: ``UNCERTAINTY_NOTE``), so U is Type A alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from estimation.pendulum.configuration import swing
from estimation.pendulum.data import PendulumGeometry
from estimation.pendulum.swing_extrema import Decay, Peaks, find_peaks
from estimation.report_numbers import (
    Coefficient,
    CoefficientWithU,
    finite_or_none,
    finite_values,
)
from estimation.stats.serial import serial_covariance
from estimation.stats.smoothing import savgol
from estimation.uncertainty.budget import coverage_factor

SG_PERIOD_FRACTION = 6  # Savitzky–Golay window ≈ period/6 ...
SG_POLYORDER = 4  # ... with a quartic: φ̈ of a sinusoid biased < 0.02 %


#: The unit of each coefficient a method row reports (the swing is a straight line).
ROW_UNITS = {
    "added_mass": "kg",
    "linear_damping": "N·s/m",
    "quadratic_damping": "N·s²/m²",
    "total_inertia": "kg·m²",
    "total_damping": "N·m·s/rad",
}


#: What a method row's U covers (every row's ``uncertainty`` key).
UNCERTAINTY_NOTE = (
    "U = k·σ (95 %, k = t_0.975(ν)): the method's own Type A; Type B not declared (the "
    "pendulum's geometry is taken as exact), so no tolerance is propagated"
)


def row_value(name: str, value: float, std: float, dof: float) -> CoefficientWithU:
    """``value`` ± ``std`` of the row's coefficient ``name`` in its unit (``ROW_UNITS``),
    with U = k·σ on ``dof`` (ν)."""
    k = coverage_factor(max(dof, 1.0))
    return CoefficientWithU(value, std, ROW_UNITS[name], k * std, k, max(dof, 1.0))


#: The symbols of a method row's coefficients, as the methods table's columns name them.
SYMBOLS = {"added_mass": "α", "linear_damping": "β", "quadratic_damping": "γ"}


@dataclass(frozen=True)
class MethodEstimate:
    """One method on one run: α (kg), β (N·s/m), γ (kg/m) or None, with σ; e and RMSE (rad)."""

    method: str
    run_id: str
    #: each a ``CoefficientWithU`` on a seed method's row; the output-error row's U is the
    #: budget's (``pendulum_estimate.pendulum_budget``)
    added_mass: Coefficient
    linear_damping: Coefficient
    quadratic_damping: Coefficient | None
    total_inertia: Coefficient  # J (kg·m²) about the pivot
    total_damping: Coefficient  # c (N·m·s/rad) about the pivot
    signal: dict[str, float]
    mse: float  # the thesis's e: mean squared deviation of the model's angle (rad²)
    rmse: float
    note: str = ""
    extra: dict = field(default_factory=dict)
    #: z of each coefficient from the output-error row of the same run
    #: (``stats.method_bias.z_scores``); None on output error's own rows
    against_output_error: dict[str, float] | None = None

    @property
    def coefficients(self) -> dict[str, Coefficient]:
        """α, β and γ (when the method gives one) by name."""
        out = {"added_mass": self.added_mass, "linear_damping": self.linear_damping}
        if self.quadratic_damping is not None:
            out["quadratic_damping"] = self.quadratic_damping
        return out

    @property
    def vs_output_error(self) -> str:
        """The row's largest z from the output-error row of its run, with its coefficient's
        symbol ("4.4 σ (α)", as the report and the page show it); "—" on output error's own
        row, "no σ" where neither gives one."""
        z = self.against_output_error
        if z is None:
            return "—"
        if not z:
            return "no σ"
        name = max(z, key=z.__getitem__)
        return f"{z[name]:.1f} σ ({SYMBOLS[name]})"

    def to_json(self) -> dict:
        """The method's row of the result document."""
        return {
            "method": self.method,
            "run_id": self.run_id,
            "added_mass": self.added_mass.to_json(),
            "linear_damping": self.linear_damping.to_json(),
            "quadratic_damping": (
                self.quadratic_damping.to_json() if self.quadratic_damping else None
            ),
            "total_inertia": self.total_inertia.to_json(),
            "total_damping": self.total_damping.to_json(),
            "signal": finite_values(self.signal),
            "mse": finite_or_none(self.mse),
            "rmse": finite_or_none(self.rmse),
            "note": self.note,
            "uncertainty": (
                UNCERTAINTY_NOTE if isinstance(self.added_mass, CoefficientWithU) else None
            ),
            "z_against_output_error": self.against_output_error,
            "vs_output_error": self.vs_output_error,
            **self.extra,
        }


# ---- signal → coefficients -----------------------------------------------------------------
def coefficients_from_signal(
    decay_rate: float,
    omega: float,
    cov: np.ndarray,
    geometry: PendulumGeometry,
    dof: float = math.inf,
) -> tuple[CoefficientWithU, CoefficientWithU, CoefficientWithU, CoefficientWithU]:
    """(J, c, α, β) with σ from K (1/s), ω (rad/s) and their 2×2 covariance, U on ν ``dof``
    (∞: a covariance taken as exact)."""
    k = geometry.restoring_stiffness()
    arm = geometry.pivot_to_vehicle_m
    s = omega**2 + decay_rate**2
    inertia = k / s
    damping = 2 * decay_rate * inertia
    # gradients w.r.t. (K, ω)
    d_inertia = np.array([-2 * decay_rate * k / s**2, -2 * omega * k / s**2])
    d_damping = 2 * inertia * np.array([1.0, 0.0]) + 2 * decay_rate * d_inertia
    cov = np.asarray(cov, dtype=float)
    sj = float(np.sqrt(max(d_inertia @ cov @ d_inertia, 0.0)))
    sc = float(np.sqrt(max(d_damping @ cov @ d_damping, 0.0)))
    alpha = (inertia - geometry.known_inertia()) / arm**2
    beta = (damping - geometry.pivot_damping_nm_s) / arm**2
    return (
        row_value("total_inertia", inertia, sj, dof),
        row_value("total_damping", damping, sc, dof),
        row_value("added_mass", alpha, sj / arm**2, dof),
        row_value("linear_damping", beta, sc / arm**2, dof),
    )


def thesis_translational(
    decay_rate: float,
    omega: float,
    arm: float,
    rod_mass: float,
    rod_cg: float,
    vehicle_mass: float,
    displaced_mass: float,
    rod_damping: float,
    g: float = 9.81,
) -> tuple[float, float]:
    """α (kg), β (N·s/m) by the thesis's translational form (seed 002 eq. 188–190).

    M = m_z·l + m̃_t·r + α·l, D = β·l + b̃·r, m̃_t = (r/l)·m_t, b̃ = (r/l)·b, with
    2K = D/M and ω² + K² = (m_z + m̃_t − ρV)·g/M. Multiplied by l this is our rotational
    form with J_t = m_t·r² (rod as a point mass), J_v = 0 and the pivot's b_rot = b·r²
    (the thesis's b is a force per m/s at the rod's CG, eq. 161).
    """
    rod_eq = rod_cg / arm * rod_mass
    big_m = (vehicle_mass + rod_eq - displaced_mass) * g / (omega**2 + decay_rate**2)
    big_d = 2 * decay_rate * big_m
    alpha = (big_m - vehicle_mass * arm - rod_eq * rod_cg) / arm
    beta = (big_d - rod_cg / arm * rod_damping * rod_cg) / arm
    return alpha, beta


# ---- the three methods -----------------------------------------------------------------------
def _signal(tau: np.ndarray, c: float, k: float, w: float, theta: float, off: float) -> np.ndarray:
    return c * np.exp(-k * tau) * np.sin(w * tau + theta) + off


def _signal_amplitude_phase(tau, phi, k, w, off) -> tuple[float, float]:
    """C, θ of C·e^{−Kτ}·sin(ωτ + θ) by linear least squares for given K, ω, offset."""
    env = np.exp(-k * tau)
    a = np.column_stack([env * np.sin(w * tau), env * np.cos(w * tau)])
    (p, q), *_ = np.linalg.lstsq(a, phi - off, rcond=None)
    return float(np.hypot(p, q)), float(np.arctan2(q, p))


def _method(
    name, decay, signal_k, signal_w, cov, dof, signal, residual, note="", extra=None
) -> MethodEstimate:
    inertia, damping, alpha, beta = coefficients_from_signal(
        signal_k, signal_w, cov, decay.geometry, dof
    )
    mse = float(np.mean(residual**2))
    return MethodEstimate(
        name, decay.run_id, alpha, beta, None, inertia, damping, signal, mse, float(np.sqrt(mse)),
        note, extra or {},
    )  # fmt: skip


def log_decrement(decay: Decay, peaks: Peaks | None = None) -> MethodEstimate:
    """The component method: K from ln|peaks| vs t, ω from the spacing of the extrema."""
    peaks = peaks or find_peaks(decay)
    k = peaks.exp_k
    w = np.pi / peaks.half_period
    w_std = np.pi / peaks.half_period**2 * peaks.half_period_std
    tau = decay.t - decay.t[0]
    c, theta = _signal_amplitude_phase(tau, decay.phi, k, w, peaks.offset)
    res = decay.phi - _signal(tau, c, k, w, theta, peaks.offset)
    signal = {"C": c, "K": k, "omega": w, "theta": theta, "offset": peaks.offset}
    cov = np.diag([peaks.exp_k_std**2, w_std**2])
    return _method(
        "log-decrement", decay, k, w, cov, peaks.times.size - 2.0, signal, res,
        f"{peaks.times.size} extrema (ν = extrema − 2); e is the damped sinusoid with these "
        "K, ω (C, θ by LS)",
    )  # fmt: skip


def damped_fit(decay: Decay, peaks: Peaks | None = None) -> MethodEstimate:
    """lsqcurvefit: C·e^{−Kτ}·sin(ωτ + θ) + offset fitted to the whole decay (least_squares)."""
    peaks = peaks or find_peaks(decay)
    tau = decay.t - decay.t[0]
    k0, w0 = max(peaks.exp_k, 1e-4), np.pi / peaks.half_period
    c0, th0 = _signal_amplitude_phase(tau, decay.phi, k0, w0, peaks.offset)
    p0 = np.array([c0, k0, w0, th0, peaks.offset])

    def resid(p):
        return _signal(tau, *p) - decay.phi

    sol = least_squares(resid, p0, method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    res = -sol.fun
    serial = serial_covariance(res, sol.jac)
    cov = serial.cov
    c, k, w, theta, off = sol.x
    if c < 0:  # the same signal with a positive amplitude
        c, theta = -c, theta + np.pi
    theta = float(np.mod(theta, 2 * np.pi))
    signal = {"C": c, "K": k, "omega": w, "theta": theta, "offset": off}
    stds = np.sqrt(np.maximum(np.diag(cov), 0.0))
    signal_std = dict(zip(("C", "K", "omega", "theta", "offset"), stds.tolist(), strict=True))
    return _method(
        "damped-fit", decay, k, abs(w), cov[1:3, 1:3], serial.dof, signal, res,
        f"y = C·e^(−Kτ)·sin(ωτ + θ) + offset, τ = t − t₀; {serial.counts}",
        {"signal_std": signal_std},
    )  # fmt: skip


def savgol_window(decay: Decay, half_period: float) -> int:
    """Savitzky–Golay window (samples): the odd number nearest period/6, at least 7."""
    dt = float(np.median(np.diff(decay.t)))
    n = round(2 * half_period / SG_PERIOD_FRACTION / dt)
    n = max(n, SG_POLYORDER + 3)
    return n if n % 2 else n + 1


def equation_error(
    decay: Decay, peaks: Peaks | None = None, quadratic: bool = True
) -> MethodEstimate:
    """Equation-error LS on smoothed derivatives (uniformly resampled), up to the last extremum.

    φ̈ = θ₁·|φ̇|·φ̇ + θ₂·φ̇ + θ₃·sin(φ − offset); ``quadratic=False`` drops θ₁.
    """
    peaks = peaks or find_peaks(decay)
    geometry, arm = decay.geometry, decay.geometry.pivot_to_vehicle_m
    window = savgol_window(decay, peaks.half_period)
    dt = float(np.median(np.diff(decay.t)))
    grid = np.arange(decay.t[0], decay.t[-1] + 0.5 * dt, dt)
    y = np.interp(grid, decay.t, decay.phi) - peaks.offset
    d1 = savgol(y, window, SG_POLYORDER, deriv=1, delta=dt)
    d2 = savgol(y, window, SG_POLYORDER, deriv=2, delta=dt)
    half = window // 2
    last = min(np.searchsorted(grid, peaks.times[-1] + 0.5 * peaks.half_period), grid.size - half)
    use = slice(half, max(last, half + 5))
    cols = [np.abs(d1) * d1, d1, np.sin(y)] if quadratic else [d1, np.sin(y)]
    a = np.column_stack(cols)[use]
    b = d2[use]
    theta, *_ = np.linalg.lstsq(a, b, rcond=None)
    serial = serial_covariance(b - a @ theta, a)
    cov, dof, p = serial.cov, serial.dof, theta.size
    th3 = float(theta[-1])
    k = geometry.restoring_stiffness()
    inertia = -k / th3
    damping = -float(theta[-2]) * inertia
    # delta method on J = −k/θ₃, c = −θ₂·J = k·θ₂/θ₃, γ·l³ = −θ₁·J = k·θ₁/θ₃
    i2, i3 = p - 2, p - 1
    g_j = np.zeros(p)
    g_j[i3] = k / th3**2
    g_c = np.zeros(p)
    g_c[i2], g_c[i3] = k / th3, -k * theta[i2] / th3**2
    sj = float(np.sqrt(max(g_j @ cov @ g_j, 0.0)))
    sc = float(np.sqrt(max(g_c @ cov @ g_c, 0.0)))
    signal = {f"theta{i + (0 if quadratic else 1) + 1}": float(v) for i, v in enumerate(theta)}
    quad = None
    if quadratic:
        g_q = np.zeros(p)
        g_q[0], g_q[i3] = k / th3, -k * theta[0] / th3**2
        q_val = k * float(theta[0]) / th3 / arm**3
        quad = row_value(
            "quadratic_damping", q_val, float(np.sqrt(max(g_q @ cov @ g_q, 0.0))) / arm**3, dof
        )
    alpha = row_value("added_mass", (inertia - geometry.known_inertia()) / arm**2, sj / arm**2, dof)
    beta = row_value(
        "linear_damping", (damping - geometry.pivot_damping_nm_s) / arm**2, sc / arm**2, dof
    )
    mse = _simulated_mse(decay, alpha.value, beta.value, quad.value if quad else 0.0, peaks)
    name = "equation-error" if quadratic else "equation-error-linear"
    note = (
        f"Savitzky–Golay window {window} samples ({window * dt:.2f} s ≈ period/6), order 4; "
        + serial.counts
    )
    return MethodEstimate(
        name, decay.run_id, alpha, beta, quad, row_value("total_inertia", inertia, sj, dof),
        row_value("total_damping", damping, sc, dof),
        signal, mse, float(np.sqrt(mse)), note, {"savgol_window": window},
    )  # fmt: skip


def _simulated_mse(decay: Decay, alpha: float, beta: float, gamma: float, peaks: Peaks) -> float:
    """e of fixed coefficients: the nonlinear model from the first sample, released at rest."""
    g = decay.geometry
    if not g.known_inertia() + alpha * g.pivot_to_vehicle_m**2 > 0:
        return float("nan")
    angle, _ = swing(decay.record(), alpha, beta, gamma, decay.phi[0] - peaks.offset)
    return float(np.mean((decay.phi - peaks.offset - angle) ** 2))
