"""The 6-DOF vehicle's motion simulated (``scipy.integrate.odeint``): the equations of
``estimation.vehicle.dynamics`` unrolled into one right-hand side, integrated from a state
under thruster commands and external forces, stopped with SingularAttitude when the pitch
reaches ±90°; and the steady state a simulated run settled into."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.vehicle.description import Vehicle6
from estimation.vehicle.dynamics import (
    SINGULAR_COS,
    SINGULAR_THETA,
    SingularAttitude,
    allocation_matrix,
    inertia_about_origin,
    mass_matrix,
)

MAX_DURATION_S = 1e6
#: Commands or forces: constant, or a function of time (s).
Input = np.ndarray | Sequence[float] | Callable[[float], Any] | None


@dataclass(frozen=True)
class Trajectory:
    """A simulated motion: times (s), η (earth frame), ν (body), applied τ (body)."""

    t: np.ndarray
    eta: np.ndarray
    nu: np.ndarray
    tau: np.ndarray

    def to_json(self, every: int = 1) -> dict:
        """Every ``every``-th sample (the last always kept) as lists, keyed by name."""
        if every < 1:
            raise ValueError(f"every: got {every!r}, allowed: an integer ≥ 1")
        idx = np.arange(0, len(self.t), every)
        if len(self.t) and idx[-1] != len(self.t) - 1:
            idx = np.append(idx, len(self.t) - 1)
        names_eta = ("x", "y", "z", "phi", "theta", "psi")
        names_nu = ("u", "v", "w", "p", "q", "r")
        names_tau = ("X", "Y", "Z", "K", "M", "N")
        out: dict[str, Any] = {"t": self.t[idx].tolist()}
        out["eta"] = {k: self.eta[idx, i].tolist() for i, k in enumerate(names_eta)}
        out["nu"] = {k: self.nu[idx, i].tolist() for i, k in enumerate(names_nu)}
        out["tau"] = {k: self.tau[idx, i].tolist() for i, k in enumerate(names_tau)}
        return out


def _commands_vector(vehicle: Vehicle6, value: Any) -> np.ndarray:
    u = np.asarray(value, dtype=float)
    n = len(vehicle.thrusters)
    if u.shape != (n,):
        raise ValueError(
            f"commands: got {u.size} value(s) (shape {u.shape}), allowed: one per thruster ({n}: "
            + ", ".join(t.name for t in vehicle.thrusters)
            + ")"
        )
    for t, c in zip(vehicle.thrusters, u.tolist(), strict=True):
        if not (math.isfinite(c) and abs(c) <= t.max_command):
            raise ValueError(
                f"commands: thruster {t.name!r}: got {c!r}, allowed: |u| ≤ {t.max_command:g}"
            )
    return u


def _force_vector(value: Any) -> np.ndarray:
    f = np.asarray(value, dtype=float)
    if f.shape != (6,) or not np.all(np.isfinite(f)):
        raise ValueError(
            f"force: got {value!r}, allowed: 6 finite numbers X, Y, Z (N), K, M, N (N·m)"
        )
    return f


def _tau_function(
    vehicle: Vehicle6, commands: Input, force: Input
) -> tuple[np.ndarray | None, Callable[[float], np.ndarray] | None]:
    """(constant τ, None) or (None, t ↦ τ(t))."""
    b = allocation_matrix(vehicle)
    parts_const = np.zeros(6)
    funcs: list[Callable[[float], np.ndarray]] = []
    if commands is not None:
        if callable(commands):
            cmd = commands
            funcs.append(lambda t: b @ _commands_vector(vehicle, cmd(t)))
        else:
            parts_const = parts_const + b @ _commands_vector(vehicle, commands)
    if force is not None:
        if callable(force):
            frc = force
            funcs.append(lambda t: _force_vector(frc(t)))
        else:
            parts_const = parts_const + _force_vector(force)
    if not funcs:
        return parts_const, None

    def tau_of_t(t: float) -> np.ndarray:
        total = parts_const.copy()
        for f in funcs:
            total += f(t)
        return total

    return None, tau_of_t


def _state(value: Any, name: str) -> np.ndarray:
    if value is None:
        return np.zeros(6)
    s = np.asarray(value, dtype=float)
    if s.shape != (6,) or not np.all(np.isfinite(s)):
        raise ValueError(f"{name}: got {value!r}, allowed: 6 finite numbers")
    return s


def _rhs_factory(
    vehicle: Vehicle6, tau_const: np.ndarray | None, tau_of_t: Callable[[float], np.ndarray] | None
) -> Callable[[float, np.ndarray], list[float]]:
    """The right-hand side written out in scalars: no numpy per call (12 states)."""
    m = vehicle.mass_kg
    xg, yg, zg = vehicle.cg_m
    xb, yb, zb = vehicle.cb_m
    w_n, b_n = vehicle.weight_n, vehicle.buoyancy_n
    wb = w_n - b_n
    gx, gy, gz = xg * w_n - xb * b_n, yg * w_n - yb * b_n, zg * w_n - zb * b_n
    a1, a2, a3, a4, a5, a6 = vehicle.added_mass
    l1, l2, l3, l4, l5, l6 = vehicle.linear_damping
    q1, q2, q3, q4, q5, q6 = vehicle.quadratic_damping
    mu, mv, mw = m + a1, m + a2, m + a3
    io = inertia_about_origin(vehicle)
    ixx, iyy, izz = float(io[0, 0]) + a4, float(io[1, 1]) + a5, float(io[2, 2]) + a6
    ixy, ixz, iyz = float(io[0, 1]), float(io[0, 2]), float(io[1, 2])
    minv = np.linalg.inv(mass_matrix(vehicle))
    diagonal = not np.any(np.abs(minv - np.diag(np.diag(minv))) > 0)
    mi = [float(x) for x in np.diag(minv)]
    rows = [[float(x) for x in row] for row in minv]
    offset = any(c != 0.0 for c in vehicle.cg_m)
    const = [float(x) for x in tau_const] if tau_const is not None else None

    def rhs(t: float, s: np.ndarray) -> list[float]:
        _, _, _, phi, th, psi, u, v, w, p, q, r = s.tolist()
        cph, sph, cth, sth = math.cos(phi), math.sin(phi), math.cos(th), math.sin(th)
        cps, sps = math.cos(psi), math.sin(psi)
        if -SINGULAR_COS < cth < SINGULAR_COS:
            raise SingularAttitude(
                f"pitch θ reached {th:g} rad at t = {t:g} s: Euler angles are singular at ±90°"
            )
        tth = sth / cth
        X, Y, Z, K, M, N = const if const is not None else tau_of_t(t).tolist()  # type: ignore[misc]
        # Coriolis: ω × ((m + A₁₁) v) and v × (A₁₁ v) + ω × ((I_o + A₂₂) ω)
        pu, pv, pw = mu * u, mv * v, mw * w
        lx = ixx * p + ixy * q + ixz * r
        ly = ixy * p + iyy * q + iyz * r
        lz = ixz * p + iyz * q + izz * r
        c1 = q * pw - r * pv
        c2 = r * pu - p * pw
        c3 = p * pv - q * pu
        c4 = v * (a3 * w) - w * (a2 * v) + q * lz - r * ly
        c5 = w * (a1 * u) - u * (a3 * w) + r * lx - p * lz
        c6 = u * (a2 * v) - v * (a1 * u) + p * ly - q * lx
        if offset:  # m ω × (ω × r_g) and m r_g × (ω × v)
            e1, e2, e3 = q * zg - r * yg, r * xg - p * zg, p * yg - q * xg
            c1 += m * (q * e3 - r * e2)
            c2 += m * (r * e1 - p * e3)
            c3 += m * (p * e2 - q * e1)
            o1, o2, o3 = q * w - r * v, r * u - p * w, p * v - q * u
            c4 += m * (yg * o3 - zg * o2)
            c5 += m * (zg * o1 - xg * o3)
            c6 += m * (xg * o2 - yg * o1)
        f = (
            X - c1 - (l1 + q1 * abs(u)) * u - wb * sth,
            Y - c2 - (l2 + q2 * abs(v)) * v + wb * cth * sph,
            Z - c3 - (l3 + q3 * abs(w)) * w + wb * cth * cph,
            K - c4 - (l4 + q4 * abs(p)) * p + gy * cth * cph - gz * cth * sph,
            M - c5 - (l5 + q5 * abs(q)) * q - gz * sth - gx * cth * cph,
            N - c6 - (l6 + q6 * abs(r)) * r + gx * cth * sph + gy * sth,
        )
        if diagonal:
            acc = [f[i] * mi[i] for i in range(6)]
        else:
            acc = [sum(row[j] * f[j] for j in range(6)) for row in rows]
        return [
            cps * cth * u + (-sps * cph + cps * sth * sph) * v + (sps * sph + cps * cph * sth) * w,
            sps * cth * u + (cps * cph + sph * sth * sps) * v + (-cps * sph + sth * sps * cph) * w,
            -sth * u + cth * sph * v + cth * cph * w,
            p + sph * tth * q + cph * tth * r,
            cph * q - sph * r,
            (sph * q + cph * r) / cth,
            *acc,
        ]

    return rhs


def simulate(
    vehicle: Vehicle6,
    duration_s: float,
    *,
    commands: Input = None,
    force: Input = None,
    dt: float = 0.01,
    eta0: Sequence[float] | None = None,
    nu0: Sequence[float] | None = None,
    rtol: float = 1e-8,
    atol: float = 1e-10,
    max_evaluations: int | None = None,
) -> Trajectory:
    """Integrate the 6-DOF equations for ``duration_s`` and sample every ``dt`` seconds.

    ``commands``: per-thruster commands, (n,) held constant or a callable t ↦ (n,);
    |u| > max_command is refused (ValueError naming the thruster), not clamped.
    ``force``: generalized body force (X, Y, Z, K, M, N), (6,) or t ↦ (6,); added to the
    thrusters' τ. Integrator: LSODA (scipy ``odeint``) to ``rtol``/``atol``, output at
    the sample times; with a callable input no step is longer than ``dt``, so an input
    pulse is seen when it lasts at least ``dt``. SingularAttitude if θ reaches ±90°;
    ValueError when the integration needs more than ``max_evaluations`` right-hand-side
    evaluations (a bound on the cost of a violent input, e.g. for a web request).
    """
    if not (isinstance(duration_s, (int, float)) and 0 < duration_s <= MAX_DURATION_S):
        raise ValueError(f"duration_s: got {duration_s!r}, allowed: 0 < d ≤ {MAX_DURATION_S:g} s")
    if not (isinstance(dt, (int, float)) and 0 < dt <= duration_s):
        raise ValueError(f"dt: got {dt!r}, allowed: 0 < dt ≤ duration_s ({duration_s:g} s)")
    n_steps = math.floor(duration_s / dt + 1e-9)
    if n_steps > 10_000_000:
        raise ValueError(f"dt: got {dt!r}, allowed: at most 1e7 samples (duration_s / dt)")
    t = np.arange(n_steps + 1) * dt
    if t[-1] < duration_s - 1e-9 * duration_s:
        t = np.append(t, duration_s)
    eta_start, nu_start = _state(eta0, "eta0"), _state(nu0, "nu0")
    tau_const, tau_of_t = _tau_function(vehicle, commands, force)
    if tau_of_t is not None:
        tau_of_t(0.0)  # refuse bad inputs before integrating
    rhs = _rhs_factory(vehicle, tau_const, tau_of_t)
    rhs(0.0, np.concatenate([eta_start, nu_start]))  # a singular start fails here, clearly
    errors: list[BaseException] = []
    budget = [max_evaluations if max_evaluations is not None else -1]

    def guarded(y: np.ndarray, time: float) -> list[float]:
        if errors:
            return [0.0] * 12
        budget[0] -= 1
        if budget[0] == 0:
            errors.append(
                ValueError(
                    f"duration_s: got {duration_s!r}, allowed: a motion that integrates in "
                    f"≤ {max_evaluations} steps (this one is too fast: reduce the input, "
                    f"the initial speed or the duration; stopped at t = {time:.6g} s)"
                )
            )
            return [0.0] * 12
        try:
            return rhs(time, y)
        except Exception as exc:  # odeint cannot carry it out; re-raised below
            errors.append(exc)
            return [0.0] * 12

    from scipy.integrate import odeint  # here: the service imports this module, never runs it

    states, info = odeint(
        guarded,
        np.concatenate([eta_start, nu_start]),
        t,
        rtol=rtol,
        atol=atol,
        mxstep=100_000,
        hmax=dt if tau_of_t is not None else 0.0,  # inputs in time are seen every dt
        full_output=True,
    )
    if errors:
        raise errors[0]
    reached = np.nonzero(np.abs(states[:, 4]) >= SINGULAR_THETA)[0]
    if reached.size:  # stepped over θ = ±90° without landing on it
        when = float(t[reached[0]])
        raise SingularAttitude(
            f"pitch θ reached ±90° by t = {when:g} s: Euler angles are singular there"
        )
    if info["message"] != "Integration successful.":
        raise RuntimeError(f"6-DOF integration failed: {info['message']}")
    if tau_const is not None:
        tau = np.tile(tau_const, (len(t), 1))
    else:
        tau = np.array([tau_of_t(x) for x in t])  # type: ignore[misc]
    return Trajectory(t=t, eta=states[:, :6], nu=states[:, 6:], tau=tau)


@dataclass(frozen=True)
class SteadyState:
    """The end of a trajectory: ν there, whether it has settled, the speed over ground."""

    nu: dict[str, float]
    settled: bool
    max_acceleration: float
    speed_m_s: float
    turn_radius_m: float | None

    def to_json(self) -> dict:
        return {
            "nu": self.nu,
            "settled": self.settled,
            "max_acceleration": self.max_acceleration,
            "speed_m_s": self.speed_m_s,
            "turn_radius_m": self.turn_radius_m,
        }


def steady_state(traj: Trajectory, window_s: float = 1.0, tolerance: float = 1e-3) -> SteadyState:
    """ν at the end; settled when every |ν̇| (finite difference over the last ``window_s``)
    is below ``tolerance`` (m/s² or rad/s²)."""
    end = traj.t[-1]
    i0 = int(np.searchsorted(traj.t, end - window_s))
    i0 = min(i0, len(traj.t) - 2) if len(traj.t) > 1 else 0
    span = traj.t[-1] - traj.t[i0]
    acc = np.abs(traj.nu[-1] - traj.nu[i0]) / span if span > 0 else np.full(6, np.inf)
    nu_end = traj.nu[-1]
    speed = float(math.hypot(nu_end[0], nu_end[1]))
    r = float(nu_end[5])
    return SteadyState(
        nu={k: float(x) for k, x in zip(("u", "v", "w", "p", "q", "r"), nu_end, strict=True)},
        settled=bool(np.all(acc < tolerance)),
        max_acceleration=float(np.max(acc)),
        speed_m_s=speed,
        turn_radius_m=speed / abs(r) if abs(r) > 1e-9 and speed > 1e-9 else None,
    )
