"""Seed 000's three least-squares approaches, as published (kept for comparison), each with
a σ and ν that hold on the residual they leave.

All solve K̂ = (HᵀH)⁻¹Hᵀτ on (M + M_drive)·ẍ + K_L·ẋ + K_Q·|ẋ|·ẋ = τ; the declared drive
inertia is moved to the left-hand side so the reported inertia is the vehicle's alone.

1. ``ls-raw``: ẋ, ẍ by backward differences of the encoder samples (eqs. 4–5, 11).
2. ``ls-curvefit``: per run ẋ = A(1 − e^{−t/T}), ẍ = (A/T)e^{−t/T} fitted to the difference
   velocities; regression as in 1 over each run's transient (0 … 4T).
3. ``ls-steady``: K_L, K_Q from the steady speeds A vs τ (eq. 12); then M from
   τ − K_L·ẋ − K_Q·|ẋ|·ẋ = M·ẍ with the curve-fit derivatives (eq. 13).

σ and ν (the rule of every regression here, ``stats.serial.serial_covariance``). The
published σ̂²(HᵀH)⁻¹,
σ̂² = SSR/(n − p), counts every sample as independent; the residual of these regressions is
not: ls-raw's derivatives are differences of the encoder samples, so one sample's noise
enters three rows, and a sensor's own low-pass or a model the curve fit misses makes it
serially correlated within a run. So σ is the larger of the white σ and the long-run
(Newey–West, AR(1)-prewhitened) sandwich of ``estimation.stats.serial`` with each run its
own record (no lag crosses a run), as the output-error fit's σ (``stats.identify``); and
ν = n_eff − p with n_eff = Σ_r n_r·(1 − r₁)/(1 + r₁) (``stats.misfit.effective_sample_size``:
r₁ the pooled lag-1 autocorrelation, clipped at 0 since a negative one adds no
information), the AR(1) variance inflation of a mean — the number of independent samples
the residual is worth, so k = t_{0.975,ν} widens where the long-run σ rests on few of them.
ls-steady's drag law has one point per run (runs are independent, each its own record: the
sandwich is then the heteroscedastic Σ gᵣgᵣᵀ), ν = runs − 2.
The budget (``uncertainty.budget.uncertainty_budget`` with ``seed=``, ``daq.axis_budget``) turns
σ, ν into U, its Type B by re-fitting the seed method (``uncertainty.tow_refits.seed_refit``).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from estimation.axis.model import BASE_NAMES
from estimation.axis.prepared_run import PreparedRun
from estimation.errors import MethodRefused
from estimation.motion.terms import force_unit
from estimation.stats.serial import SerialCovariance, serial_covariance

TRANSIENT_TIME_CONSTANTS = 4.0  # the paper's "time to steady state" ≈ 4T


@dataclass(frozen=True)
class LeastSquaresFit:
    """Coefficients (inertia, K_L, K_Q) with σ and correlation from one seed approach."""

    method: str
    names: tuple[str, ...]
    values: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    curve_fits: tuple[tuple[float, float], ...] = ()  # (A, T) per run for 2 and 3
    #: ν of each coefficient's σ (module doc: n_eff − p of its regression)
    dof: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: the published white σ̂²(HᵀH)⁻¹ alone (its diagonal never above ``std``²)
    cov_white: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    #: n, n_eff and p of each regression, as the budget's row notes them
    counts: str = ""

    @property
    def std_white(self) -> np.ndarray:
        """The published white σ of each coefficient."""
        return np.sqrt(np.maximum(np.diag(self.cov_white), 0.0))

    @property
    def covariance(self) -> np.ndarray:
        """The coefficients' covariance: σ (the larger) with the long-run correlation."""
        return np.outer(self.std, self.std) * self.correlation


def _solve(h: np.ndarray, y: np.ndarray, sizes: Sequence[int] | None = None):
    """K̂ = (HᵀH)⁻¹Hᵀy and its covariance over records of ``sizes`` rows (module doc)."""
    k = np.linalg.pinv(h.T @ h) @ h.T @ y
    return k, serial_covariance(y - h @ k, h, sizes)


def _fit(method: str, solved: tuple[np.ndarray, SerialCovariance], fits=()) -> LeastSquaresFit:
    """The seed fit of one regression over (inertia, K_L, K_Q)."""
    k, c = solved
    return LeastSquaresFit(
        method, BASE_NAMES, k, np.sqrt(np.diag(c.cov)), _corr(c.cov), fits,
        np.full(k.size, c.dof), c.cov_white, c.counts,
    )  # fmt: skip


def _corr(cov: np.ndarray) -> np.ndarray:
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    denom = np.outer(std, std)
    return np.divide(cov, denom, out=np.eye(cov.shape[0]), where=denom > 0)


def _moving(run: PreparedRun) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times since release, positions and drive from the last at-rest sample onwards."""
    start = max(int(np.searchsorted(run.t, run.t_release, side="right")) - 1, 0)
    return run.t[start:] - run.t_release, run.x[start:], run.drive[start:]


def _differences(run: PreparedRun):
    tau, x, drive = _moving(run)
    dt = np.diff(tau)
    v = np.diff(x) / dt
    a = np.diff(v) / dt[1:]
    return tau[2:], v[1:], a, drive[2:], tau[1:], v


def ls_raw(runs: Sequence[PreparedRun]) -> LeastSquaresFit:
    """Approach 1: regress τ on [ẍ, ẋ, |ẋ|ẋ] with derivatives from backward differences."""
    rows, ys = [], []
    for r in runs:
        _, v, a, drive, _, _ = _differences(r)
        rows.append(np.column_stack([a, v, np.abs(v) * v]))
        ys.append(drive - r.extra_inertia * a)
    sizes = [y.size for y in ys]
    return _fit("ls-raw", _solve(np.vstack(rows), np.concatenate(ys), sizes))


def one_way_drives(runs: Sequence[PreparedRun], method: str) -> None:
    """Refuse a run whose drive reverses after its release (``MethodRefused`` naming it): a
    first-order rise from rest, ẋ = A(1 − e^{−t/T}), is the response to one drive held in
    one direction, and a drive that changes sign (a reversing thruster profile, a wave's
    force) has neither that rise nor a steady speed. Only a sign change counts, which no
    constant drive makes whatever its noise: a drive that steps within one direction is
    left to the result's σ and its comparison with the output-error fit."""
    for r in runs:
        _, _, drive = _moving(r)
        if np.any(drive > 0) and np.any(drive < 0):
            unit = force_unit(r.dof)
            raise MethodRefused(
                f"runs: {r.run_id}: drive: got a drive that reverses after the release "
                f"({float(drive.min()):.4g} to {float(drive.max()):.4g} {unit}), allowed: one "
                f"direction per run for {method} (a first-order rise from rest under one "
                "drive); output-error and ls-raw take any drive"
            )


def first_order_fit(run: PreparedRun) -> tuple[float, float]:
    """Fit ẋ = A(1 − e^{−t/T}) to the difference velocities of one run; returns (A, T)."""
    from scipy.optimize import OptimizeWarning, curve_fit  # the service imports this module

    _, _, _, _, tau_v, v = _differences(run)
    t_mid = tau_v - 0.5 * np.diff(np.concatenate([[0.0], tau_v]))
    a0 = float(np.mean(v[-max(v.size // 4, 1) :]))
    t0 = float(t_mid[np.argmax(np.abs(v) >= 0.63 * abs(a0))]) or 0.5
    with warnings.catch_warnings():  # σ of (A, T) is not used: only the curve is
        warnings.simplefilter("ignore", OptimizeWarning)
        (amp, tc), _ = curve_fit(
            lambda t, amp, tc: amp * (1.0 - np.exp(-t / tc)),
            t_mid,
            v,
            p0=(a0, max(t0, 0.05)),
            maxfev=5000,
        )
    return float(amp), float(abs(tc))


def _curve_rows(run: PreparedRun, amp: float, tc: float):
    tau, _, drive = _moving(run)
    keep = (tau > 0) & (tau <= TRANSIENT_TIME_CONSTANTS * tc)
    e = np.exp(-tau[keep] / tc)
    return amp * (1 - e), amp / tc * e, drive[keep]


def distinct_drives(runs: Sequence[PreparedRun], method: str) -> np.ndarray:
    """The runs' mean drives (signed), or ``MethodRefused`` when they hold fewer than two
    distinct levels: a first-order curve gives two numbers per run (its steady speed A and
    time constant T), and one drive level's curves are fitted exactly by a one-parameter
    family of (M, K_L, K_Q) with K_Q = 0 — a residual of zero that says nothing of the noise
    and a drag law the records never tested."""
    drives = np.array([r.mean_abs_drive * np.sign(np.mean(r.drive)) for r in runs])
    if np.unique(np.round(np.abs(drives), 9)).size < 2:
        unit = force_unit(runs[0].dof) if runs else "N"
        levels = ", ".join(f"{d:.4g}" for d in sorted(set(np.round(np.abs(drives), 9))))
        raise MethodRefused(
            f"runs: drive: got one drive level ({levels} {unit}), allowed: two or more "
            f"different forces/torques for {method} (a first-order curve per run gives its "
            "steady speed and time constant only); output-error and ls-raw take one run"
        )
    return drives


def ls_curvefit(runs: Sequence[PreparedRun]) -> LeastSquaresFit:
    """Approach 2: regress τ on the first-order curve-fit derivatives over each transient."""
    one_way_drives(runs, "ls-curvefit")
    distinct_drives(runs, "ls-curvefit")
    fits = tuple(first_order_fit(r) for r in runs)
    rows, ys = [], []
    for r, (amp, tc) in zip(runs, fits, strict=True):
        v, a, drive = _curve_rows(r, amp, tc)
        rows.append(np.column_stack([a, v, np.abs(v) * v]))
        ys.append(drive - r.extra_inertia * a)
    sizes = [y.size for y in ys]
    return _fit("ls-curvefit", _solve(np.vstack(rows), np.concatenate(ys), sizes), fits)


def ls_steady(runs: Sequence[PreparedRun]) -> LeastSquaresFit:
    """Approach 3: drag law from steady speeds vs drive, then inertia from the transients."""
    one_way_drives(runs, "ls-steady")
    drives = distinct_drives(runs, "ls-steady")
    fits = tuple(first_order_fit(r) for r in runs)
    speeds = np.array([amp for amp, _ in fits])
    # one point per run, runs independent: white σ, ν = runs − 2
    kd, drag = _solve(np.column_stack([speeds, np.abs(speeds) * speeds]), drives, [1] * len(runs))
    lhs, rhs = [], []
    for r, (amp, tc) in zip(runs, fits, strict=True):
        v, a, drive = _curve_rows(r, amp, tc)
        lhs.append(a)
        rhs.append(drive - kd[0] * v - kd[1] * np.abs(v) * v - r.extra_inertia * a)
    km, mass = _solve(np.concatenate(lhs)[:, None], np.concatenate(rhs), [a.size for a in lhs])
    values = np.array([km[0], kd[0], kd[1]])
    cov, white = np.zeros((3, 3)), np.zeros((3, 3))
    cov[0, 0], cov[1:, 1:] = mass.cov[0, 0], drag.cov
    white[0, 0], white[1:, 1:] = mass.cov_white[0, 0], drag.cov_white
    return LeastSquaresFit(
        "ls-steady", BASE_NAMES, values, np.sqrt(np.diag(cov)), _corr(cov), fits,
        np.array([mass.dof, drag.dof, drag.dof]), white,
        f"inertia: {mass.counts}; drag law: {drag.counts}",
    )  # fmt: skip


SEED_METHODS = {"ls-raw": ls_raw, "ls-curvefit": ls_curvefit, "ls-steady": ls_steady}
