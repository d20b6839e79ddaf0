"""6-DOF vehicle dynamics in Fossen's form (``estimation.vehicle.simulation`` integrates them).

    (M_RB + M_A) ν̇ + (C_RB(ν) + C_A(ν)) ν + D(ν) ν + g(η) = τ,        η̇ = J(η) ν

ν = (u, v, w, p, q, r) in the body frame (x forward, y starboard, z down, origin at the
body reference point), η = (x, y, z, φ, θ, ψ) in the earth frame (north, east, down; zyx
Euler angles). M_A = diag(added_mass), D(ν) = diag(K_L) + diag(K_Q)·|ν|,

    C_RB(ν) = [[0, −m S(ν₁) − m S(ν₂) S(r_g)], [−m S(ν₁) + m S(r_g) S(ν₂), −S(I_o ν₂)]]
    C_A(ν)  = [[0, −S(A₁₁ ν₁)], [−S(A₁₁ ν₁), −S(A₂₂ ν₂)]]          (diagonal added mass)

both skew-symmetric, so the Coriolis terms do no work. g(η) is Fossen's restoring vector
(left-hand side convention) from W = m g at the CG and B at the CB. τ = B_t u + τ_ext with
the allocation matrix B_t (column i = gain_i · [d_i; r_i × d_i]).

Seed 001 (Nguyễn Ngọc Tuệ's AUV thesis) is followed with its typos corrected:
(2.6) "[M_RB − M_A]" and (2.7) "ν̇ = M⁻¹(Cν + Dν + g + τ)" → (M_RB + M_A)ν̇ = τ − Cν − Dν − g;
(2.9) sway "−wr" → "−wp", heave "z_g(q²+q²)" → "z_g(p²+q²)", yaw's second bracket times
y_g (not z_g); (2.12) C_RB₂ used as −C_RB₁ᵀ (the extracted block has flipped u, v, w
signs); (2.21) the buoyancy moment uses the CB (x_b, y_b, z_b), not the CG; (2.22) the
printed leading "−" in front of g(η) dropped (it clashes with +g(η) on the left of (2.6)).
Seed 002's B matrix is reproduced by ``allocation_matrix`` up to its frame (z up there)
and its rotational rows' ×100 scale error.

These are the readable matrices; the simulator integrates an unrolled copy of them, and the
tests check the two against each other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from estimation.vehicle.description import DOFS, Vehicle6

#: Largest |cos θ| treated as the Euler-angle singularity (θ = ±90°).
SINGULAR_COS = 1e-6
#: The pitch angle (rad) at which that happens.
SINGULAR_THETA = math.acos(SINGULAR_COS)


class SingularAttitude(ValueError):
    """The pitch angle reached ±90°, where the Euler-angle kinematics J₂(η) are singular."""


def skew(a: Sequence[float] | np.ndarray) -> np.ndarray:
    """S(a) with S(a) b = a × b."""
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def inertia_about_origin(vehicle: Vehicle6) -> np.ndarray:
    s = skew(vehicle.cg_m)
    return np.diag(vehicle.inertia_kg_m2) - vehicle.mass_kg * s @ s


def mass_matrix(vehicle: Vehicle6) -> np.ndarray:
    """M = M_RB + M_A (6×6), M_RB = [[m I, −m S(r_g)], [m S(r_g), I_o]]."""
    m = vehicle.mass_kg
    sg = skew(vehicle.cg_m)
    mrb = np.block([[m * np.eye(3), -m * sg], [m * sg, inertia_about_origin(vehicle)]])
    return mrb + np.diag(vehicle.added_mass)


def coriolis_matrix(vehicle: Vehicle6, nu: Sequence[float] | np.ndarray) -> np.ndarray:
    """C(ν) = C_RB(ν) + C_A(ν) (6×6, skew-symmetric)."""
    m = vehicle.mass_kg
    v = np.asarray(nu, dtype=float)
    v1, v2 = v[:3], v[3:]
    sg = skew(vehicle.cg_m)
    c12 = -m * skew(v1) - m * skew(v2) @ sg
    crb = np.block([[np.zeros((3, 3)), c12], [-c12.T, -skew(inertia_about_origin(vehicle) @ v2)]])
    a = np.asarray(vehicle.added_mass)
    a1, a2 = skew(a[:3] * v1), skew(a[3:] * v2)
    ca = np.block([[np.zeros((3, 3)), -a1], [-a1, -a2]])
    return crb + ca


def damping_matrix(vehicle: Vehicle6, nu: Sequence[float] | np.ndarray) -> np.ndarray:
    """D(ν) = diag(K_L) + diag(K_Q)·|ν|."""
    speed = np.abs(np.asarray(nu, dtype=float))
    return np.diag(
        np.asarray(vehicle.linear_damping) + np.asarray(vehicle.quadratic_damping) * speed
    )


def restoring_force(vehicle: Vehicle6, eta: Sequence[float]) -> np.ndarray:
    """Fossen's g(η) (left-hand side: the restoring force acting is −g(η))."""
    _, _, _, phi, theta, _ = np.asarray(eta, dtype=float)
    w, b = vehicle.weight_n, vehicle.buoyancy_n
    xg, yg, zg = vehicle.cg_m
    xb, yb, zb = vehicle.cb_m
    sth, cth, sph, cph = math.sin(theta), math.cos(theta), math.sin(phi), math.cos(phi)
    return np.array(
        [
            (w - b) * sth,
            -(w - b) * cth * sph,
            -(w - b) * cth * cph,
            -(yg * w - yb * b) * cth * cph + (zg * w - zb * b) * cth * sph,
            (zg * w - zb * b) * sth + (xg * w - xb * b) * cth * cph,
            -(xg * w - xb * b) * cth * sph - (yg * w - yb * b) * sth,
        ]
    )


def kinematics_matrix(eta: Sequence[float]) -> np.ndarray:
    """J(η) = diag(J₁, J₂) with η̇ = J(η) ν (SingularAttitude at θ = ±90°)."""
    _, _, _, phi, theta, psi = np.asarray(eta, dtype=float)
    cph, sph, cth, sth = math.cos(phi), math.sin(phi), math.cos(theta), math.sin(theta)
    cps, sps = math.cos(psi), math.sin(psi)
    if abs(cth) < SINGULAR_COS:
        raise SingularAttitude(f"pitch θ = {theta:g} rad: Euler angles are singular at ±90°")
    j1 = np.array(
        [
            [cps * cth, -sps * cph + cps * sth * sph, sps * sph + cps * cph * sth],
            [sps * cth, cps * cph + sph * sth * sps, -cps * sph + sth * sps * cph],
            [-sth, cth * sph, cth * cph],
        ]
    )
    j2 = np.array(
        [[1.0, sph * sth / cth, cph * sth / cth], [0.0, cph, -sph], [0.0, sph / cth, cph / cth]]
    )
    out = np.zeros((6, 6))
    out[:3, :3], out[3:, 3:] = j1, j2
    return out


def allocation_matrix(vehicle: Vehicle6) -> np.ndarray:
    """B_t (6 × n_thrusters): column i = gain_i · [d_i; r_i × d_i], so τ = B_t u."""
    cols = []
    for t in vehicle.thrusters:
        d, r = np.asarray(t.direction), np.asarray(t.position_m)
        cols.append(t.gain_n_per_command * np.concatenate([d, np.cross(r, d)]))
    return np.array(cols).T if cols else np.zeros((6, 0))


def resisting_force(vehicle: Vehicle6, eta: Sequence[float], nu: Sequence[float]) -> np.ndarray:
    """C(ν)ν + D(ν)ν + g(η): the τ that holds the state ``(η, ν)`` unaccelerated."""
    v = np.asarray(nu, dtype=float)
    return (
        coriolis_matrix(vehicle, v) @ v
        + damping_matrix(vehicle, v) @ v
        + restoring_force(vehicle, eta)
    )


def state_derivative(
    vehicle: Vehicle6, eta: Sequence[float], nu: Sequence[float], tau: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """(η̇, ν̇) from the matrix form (slow, readable; the reference for the simulator)."""
    eta_dot = kinematics_matrix(eta) @ np.asarray(nu, dtype=float)
    nu_dot = np.linalg.solve(
        mass_matrix(vehicle), np.asarray(tau) - resisting_force(vehicle, eta, nu)
    )
    return eta_dot, nu_dot


__all__ = [
    "DOFS",
    "SingularAttitude",
    "allocation_matrix",
    "coriolis_matrix",
    "damping_matrix",
    "kinematics_matrix",
    "mass_matrix",
    "resisting_force",
    "restoring_force",
    "state_derivative",
]
