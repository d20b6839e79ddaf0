"""Synthetic pendulum free-decay records from an integrator independent of the estimator.

solve_ivp (RK45, tight tolerances) of

    (J_t + m_z·l² + J_v + α·l²)·φ̈ = −[(m_z − ρV)·l + m_t·r]·g·sin φ − (β·l² + b)·φ̇
                                     − γ·l³·|φ̇|·φ̇ − κ·l⁴·φ̇³ − τ_c·sgn φ̇

integrated half-swing by half-swing: an event at φ̇ = 0 ends each one; the pendulum sticks
there for good when |k·sin φ| ≤ τ_c. Sampled at 10 Hz, encoder-quantized, with noise.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from scipy.integrate import solve_ivp

from estimation.pendulum.data import PendulumGeometry, PendulumRun

#: A rig like seed 002's (rod 7.88 kg, CG 0.495 m; vehicle 40.9 kg at 1.205 m), the vehicle
#: 2 kg heavy in water so that it, not only the rod, pulls the pendulum back.
GEOMETRY = PendulumGeometry(
    pivot_to_vehicle_m=1.205,
    rod_mass_kg=7.88,
    rod_cg_m=0.495,
    rod_inertia_kg_m2=2.95,
    vehicle_mass_kg=40.9,
    vehicle_inertia_kg_m2=0.6,
    buoyancy_kg=38.9,
    pivot_damping_nm_s=0.23,
    g=9.81,
)
ALPHA, BETA = 30.0, 12.0  # kg, N·s/m: lighter damping than the thesis, ≈ 5 swings to rest
QUANTUM = 1e-5  # rad
NOISE = 2e-5  # rad (1σ)


def decay(
    geometry: PendulumGeometry = GEOMETRY,
    alpha: float = ALPHA,
    beta: float = BETA,
    gamma: float = 0.0,
    cubic_drag: float = 0.0,
    dry_friction: float = 0.0,
    amplitude: float = 0.25,
    duration: float = 40.0,
    rate_hz: float = 10.0,
    noise: float = NOISE,
    offset: float = 0.0,
    seed: int = 7,
    run_id: str = "p1",
    t_release: float = 1.0,
) -> PendulumRun:
    """One run: held at ``amplitude`` for ``t_release`` s, then released; ``gamma`` (kg/m)
    and ``cubic_drag`` (κ, N·s³/m³) are the vehicle's, at lever arm l. ``seed`` draws the
    noise only: the swing itself is integrated once per physics (``_swing``)."""
    t, phi = _swing(
        geometry, alpha, beta, gamma, cubic_drag, dry_friction, amplitude, duration, rate_hz,
        t_release,
    )  # fmt: skip
    rng = np.random.default_rng(seed)
    measured = np.round((phi + offset + noise * rng.standard_normal(t.size)) / QUANTUM) * QUANTUM
    return PendulumRun(run_id, t.copy(), measured, t_release, geometry, "surge", 0.005)


@cache
def _swing(
    geometry: PendulumGeometry,
    alpha: float,
    beta: float,
    gamma: float,
    cubic_drag: float,
    dry_friction: float,
    amplitude: float,
    duration: float,
    rate_hz: float,
    t_release: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The true swing (rad) at the sample times (s), read-only: it depends on the physics,
    not on the seed, and an integration costs ~0.4 s of CPU (a 50-seed test draws 100)."""
    g = geometry
    arm = g.pivot_to_vehicle_m
    inertia = g.known_inertia() + alpha * arm**2
    k = g.restoring_stiffness()
    c = beta * arm**2 + g.pivot_damping_nm_s
    q = gamma * arm**3
    cube = cubic_drag * arm**4
    t_end = t_release + duration
    times, angles = [np.array([t_release])], [np.array([amplitude])]
    state, t0 = np.array([amplitude, 0.0]), t_release
    while t0 < t_end:
        phi, v = state
        if v == 0 and k * abs(np.sin(phi)) <= dry_friction:
            break  # stuck for good
        sign = np.sign(v) if v != 0 else -np.sign(np.sin(phi))

        def rhs(_t, y, sign=sign):
            return [y[1], (-k * np.sin(y[0]) - c * y[1] - q * abs(y[1]) * y[1]
                           - cube * y[1] ** 3 - dry_friction * sign) / inertia]  # fmt: skip

        def turn(_t, y):
            return y[1]

        turn.terminal, turn.direction = True, -sign
        sol = solve_ivp(
            rhs, (t0, t_end), state, events=turn, rtol=1e-11, atol=1e-13, dense_output=True,
            first_step=1e-3,
        )  # fmt: skip
        tt = np.linspace(t0, sol.t[-1], max(int((sol.t[-1] - t0) * 200), 2))
        times.append(tt[1:])
        angles.append(sol.sol(tt)[0][1:])
        if sol.status == 1:
            state, t0 = np.array([sol.y_events[0][0][0], 0.0]), float(sol.t_events[0][0])
        else:
            break
    dense_t, dense_phi = np.concatenate(times), np.concatenate(angles)
    t = np.arange(0.0, t_end, 1.0 / rate_hz)
    phi = np.where(t < t_release, amplitude, np.interp(t, dense_t, dense_phi))
    t.setflags(write=False)
    phi.setflags(write=False)
    return t, phi
