"""Test-side data generator: integrates the TRUE rig physics finely, independent of estimation.

Three bodies joined by an inextensible cord: the vehicle (inertia M), the pulley or drum
(J) and the hung weight (m_w). Cord tensions are eliminated by hand here:
    surge: (M + m_w + J_p/r_p²)·ẍ = m_w·g − D(ẋ) − extras
    yaw:   (I + m_w·r_d² + J_d)·ψ̈ = m_w·g·r_d − D(ψ̇) − extras
integrated with RK4 at 1 kHz, sampled at ``rate_hz`` with timestamp jitter, quantized to the
encoder step.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np

from estimation.data.run_arrays import RunData

G_RIG = 9.8
SURGE_TRUTH = (143.26, 20.16, 241.14)
YAW_TRUTH = (7.97, 0.119, 4.12)
SURGE_FORCES = (4.9, 24.5, 44.1, 83.3)
YAW_TORQUES = (0.454, 0.907, 1.361, 2.269)
PULLEY_RADIUS_M, PULLEY_J = 0.05, 0.0005
DRUM_RADIUS_M, DRUM_J = 0.0926, 0.001


@dataclass(frozen=True)
class Physics:
    """True plant: base coefficients plus optional rig effects (all SI, axis units)."""

    inertia: float
    linear_damping: float
    quadratic_damping: float
    coulomb: float = 0.0  # kinetic dry friction
    static: float = 0.0  # breakaway force (≥ coulomb when used)
    bias: float = 0.0  # force that does not flip with direction
    spring: float = 0.0  # restoring stiffness about the release position
    cubic: float = 0.0  # cubic drag coefficient
    delay: float = 0.0  # brake release lag, s
    ripple: float = 0.0  # amplitude of a force periodic along the rail (outside the library)
    ripple_wavelength: float = 0.5  # its period in position, m (or rad)

    def rail_force(self, x: float) -> float:
        """The periodic rail force at displacement ``x`` from the release point."""
        return self.ripple * np.sin(2 * np.pi * x / self.ripple_wavelength) if self.ripple else 0.0


def _sign(value: float) -> float:
    """``np.sign`` of one float (0.0 at zero), without numpy's per-call cost."""
    return 1.0 if value > 0 else (-1.0 if value < 0 else 0.0)


@lru_cache(maxsize=64)
def _integrate(phys: Physics, total_inertia: float, drive: float, duration: float, dt: float):
    """RK4 at ``dt`` from rest; scalar Python floats (30 000 steps: numpy scalars cost 4×)."""
    n = int(np.ceil(duration / dt)) + 1
    bias, spring, rail = phys.bias, phys.spring, (phys.rail_force if phys.ripple else None)
    k_l, k_q, k_c, coulomb = phys.linear_damping, phys.quadratic_damping, phys.cubic, phys.coulomb
    held = max(phys.static, phys.coulomb)

    def accel(x: float, v: float) -> float:
        net = drive + bias - spring * x + (rail(x) if rail else 0.0)
        net -= k_l * v + k_q * abs(v) * v + k_c * v**3
        if v == 0.0:
            if abs(net) <= held:
                return 0.0
            return (net - coulomb * _sign(net)) / total_inertia
        return (net - coulomb * _sign(v)) / total_inertia

    xs = [0.0] * n
    x = v = 0.0
    half, sixth = 0.5 * dt, dt / 6
    for k in range(1, n):
        a1 = accel(x, v)
        v2 = v + half * a1
        a2 = accel(x + half * v, v2)
        v3 = v + half * a2
        a3 = accel(x + half * v2, v3)
        v4 = v + dt * a3
        a4 = accel(x + dt * v3, v4)
        new_v = v + sixth * (a1 + 2 * a2 + 2 * a3 + a4)
        x = x + sixth * (v + 2 * v2 + 2 * v3 + v4)
        v = 0.0 if v != 0.0 and _sign(new_v) != _sign(v) and coulomb > 0 else new_v
        xs[k] = x
    return np.arange(n) * dt, np.array(xs)


def weight_run(
    phys: Physics,
    drive: float,
    *,
    axis: str = "surge",
    run_id: str = "run",
    rng: np.random.Generator | None = None,
    quantum: float = 1e-4,
    rate_hz: float = 10.0,
    jitter_s: float = 0.002,
    duration_s: float = 30.0,
    travel_limit: float | None = None,
    baseline_s: float = 1.0,
    declare_hung_mass: bool = True,
    fine_dt: float = 1e-3,
) -> RunData:
    """One weight-driven run: drive in N (surge) or N·m (yaw), sampled and quantized."""
    rng = rng or np.random.default_rng(0)
    if axis == "surge":
        hung = abs(drive) / G_RIG
        drive_j = PULLEY_J / PULLEY_RADIUS_M**2
        total = phys.inertia + hung + drive_j
        limit = 5.5 if travel_limit is None else travel_limit
        radius = None
    else:
        hung = abs(drive) / (G_RIG * DRUM_RADIUS_M)
        drive_j = DRUM_J
        total = phys.inertia + hung * DRUM_RADIUS_M**2 + drive_j
        limit = 37.7 if travel_limit is None else travel_limit
        radius = DRUM_RADIUS_M
    t_fine, x_fine = _integrate(phys, total, drive, duration_s, fine_dt)
    beyond = np.nonzero(np.abs(x_fine) >= limit)[0]
    motion_end = t_fine[beyond[0]] if beyond.size else duration_s
    t_release = baseline_s
    nominal = np.arange(0.0, t_release + phys.delay + motion_end, 1.0 / rate_hz)
    t = nominal + rng.normal(0.0, jitter_s, nominal.size)
    t[0] = 0.0
    t = np.maximum.accumulate(t + 1e-9 * np.arange(t.size))
    tau = np.clip(t - t_release - phys.delay, 0.0, None)
    x_true = 0.37 + np.interp(tau, t_fine, x_fine)  # arbitrary encoder zero
    position = np.floor(x_true / quantum) * quantum
    return RunData(
        run_id=run_id,
        axis=axis,  # type: ignore[arg-type]
        t=t,
        position=position,
        drive=float(drive),
        hung_mass_kg=hung if declare_hung_mass else None,
        drive_inertia=drive_j,
        drum_radius_m=radius,
        t_release=t_release,
    )


def tow_set(
    phys: Physics | None = None, *, axis: str = "surge", seed: int = 0, drives=None, **kw
) -> list[RunData]:
    """Four runs at the seed's forces (surge) or torques (yaw)."""
    if phys is None:
        phys = Physics(*(SURGE_TRUTH if axis == "surge" else YAW_TRUTH))
    if drives is None:
        drives = SURGE_FORCES if axis == "surge" else YAW_TORQUES
    rng = np.random.default_rng(seed)
    return [
        weight_run(phys, d, axis=axis, run_id=f"{axis}-{i}", rng=rng, **kw)
        for i, d in enumerate(drives)
    ]


PAPER_CURVES = {
    "surge": ((0.11, 0.27, 0.38, 0.51), (1.0, 1.0, 0.75, 0.75), SURGE_FORCES),
    "yaw": ((0.31, 0.44, 0.56, 0.74), (2.75, 2.75, 2.25, 2.25), YAW_TORQUES),
}


def paper_curve_runs(
    axis: Literal["surge", "yaw"], quantum: float = 1e-4, seconds_after: float = 3.0
):
    """Runs regenerated from seed 000's published first-order fits ẋ = A(1 − e^{−t/T}).

    Position x = A(t − T(1 − e^{−t/T})), sampled at 10 Hz, quantized; no hung mass declared
    (the paper's coefficients include the weight), 1 s baseline, 4T + ``seconds_after`` long.
    """
    runs = []
    for i, (amp, tc, drive) in enumerate(zip(*PAPER_CURVES[axis], strict=True)):
        t = np.arange(0.0, 1.0 + 4 * tc + seconds_after, 0.1)
        tau = np.clip(t - 1.0, 0.0, None)
        x = amp * (tau - tc * (1 - np.exp(-tau / tc)))
        runs.append(
            RunData(
                f"paper-{axis}-{i}",
                axis,
                t,
                np.floor(x / quantum) * quantum,  # type: ignore[arg-type]
                drive,
                t_release=1.0,
            )
        )
    return runs


def thruster_run(
    phys: Physics,
    levels: tuple[float, ...],
    *,
    hold_s: float = 8.0,
    run_id: str = "thr",
    quantum: float = 1e-4,
    baseline_s: float = 1.0,
    fine_dt: float = 1e-3,
) -> RunData:
    """A thruster-driven surge run: thrust held at each level for ``hold_s`` (no weight).

    Thrust changes exactly at 10 Hz sample instants (no jitter) and is recorded per sample.
    """
    n_fine = round((baseline_s + hold_s * len(levels)) / fine_dt)
    t_fine = np.arange(n_fine + 1) * fine_dt
    level_idx = np.clip(((t_fine - baseline_s) // hold_s).astype(int), 0, len(levels) - 1)
    thrust = np.where(t_fine < baseline_s, 0.0, np.array(levels)[level_idx])
    x = v = 0.0
    xs = np.zeros(t_fine.size)
    inertia = phys.inertia

    bias, spring, rail = phys.bias, phys.spring, (phys.rail_force if phys.ripple else None)
    k_l, k_q, k_c, coulomb = phys.linear_damping, phys.quadratic_damping, phys.cubic, phys.coulomb

    def accel(v: float, x: float, f: float) -> float:
        net = f + bias - spring * x + (rail(x) if rail else 0.0) - k_l * v
        net -= k_q * abs(v) * v + k_c * v**3
        if v == 0.0:
            return 0.0 if abs(net) <= coulomb else (net - coulomb * _sign(net)) / inertia
        return (net - coulomb * _sign(v)) / inertia

    thrust_steps, t_steps = thrust.tolist(), t_fine.tolist()  # Python floats: 4× faster
    for k in range(1, t_fine.size):
        f = thrust_steps[k - 1]  # held over the step (changes fall on the ms grid)
        if t_steps[k - 1] < baseline_s:
            continue
        a1 = accel(v, x, f)
        a2 = accel(v + 0.5 * fine_dt * a1, x + 0.5 * fine_dt * v, f)
        a3 = accel(v + 0.5 * fine_dt * a2, x + 0.5 * fine_dt * (v + 0.5 * fine_dt * a1), f)
        a4 = accel(v + fine_dt * a3, x + fine_dt * (v + 0.5 * fine_dt * a2), f)
        new_v = v + fine_dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        x += fine_dt * v + fine_dt**2 / 6 * (a1 + a2 + a3)
        v = 0.0 if v != 0.0 and _sign(new_v) != _sign(v) and coulomb > 0 else new_v
        xs[k] = x
    step = round(0.1 / fine_dt)
    t = t_fine[::step]
    position = np.floor((0.5 + xs[::step]) / quantum) * quantum
    return RunData(run_id, "surge", t, position, thrust[::step].copy(), t_release=baseline_s)
