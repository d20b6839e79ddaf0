"""The pendulum as a configuration of the one equation of motion (``estimation.motion``).

    (J_known + α·l²)·φ̈ = −k·sin φ − (β·l² + b)·φ̇ [− γ·l³·|φ̇|·φ̇] [− κ·l⁴·φ̇³] [− τ_c·sgn φ̇]

x = φ (rad), a rotation about the horizontal pivot. What the rig's geometry gives is known,
per record (each run carries its own geometry, so runs on different rods fit jointly):

- the known inertia J_known = J_t + m_z·l² + J_v (``Record.known_inertia``);
- gravity's restoring moment k·sin φ, k = [(m_z − ρV)·l + m_t·r]·g (library term
  ``sine_restoring`` with a known coefficient);
- the pivot's measured viscous torque b (a known part of ``linear_damping``).

Identified: α (the identified inertia), β (``linear_damping``) and the library candidates
(``CANDIDATES``): γ (``quadratic_damping``), τ_c (``coulomb_friction``), κ (``cubic_drag``).
**Weights** (``Record.weights``): the vehicle sits at lever arm l and moves at l·φ̇, so a
term of its hydrodynamics whose force grows like |ẋ|^(p−1)·ẋ (the entry's ``v_power``
p ≥ 1) exerts the moment θ·l^(p+1)·|φ̇|^(p−1)·φ̇ — weight l^(p+1) — and its inertia weighs
l²; a term whose force does not grow with speed (dry friction, p = 0) is the pivot's own
moment: weight 1. So α, β, γ, κ keep the vehicle's translational units (kg, N·s/m,
N·s²/m² = kg/m, N·s³/m³) and τ_c is in N·m.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.motion.fit import MotionFit, fit_motion, simulate
from estimation.motion.records import Record, Setup
from estimation.motion.terms import LIBRARY
from estimation.pendulum.data import PendulumGeometry

#: φ is a rotation (about the pivot): the equation's coefficients are per rad.
PIVOT_DOF = "roll"
#: Identified in every fit besides the inertia.
BASE_TERMS: tuple[str, ...] = ("linear_damping",)
#: The effect search's candidates, in library order (the earlier of two rivals is the
#: conventional one): every force entry the geometry carries — the vehicle's damping, a
#: force growing with speed (``v_power`` ≥ 1, weight l^(p+1)), and the pivot's dry friction
#: (set-valued at rest, weight 1). Not tried: restoring terms (gravity's moment is known from
#: the geometry, ``sine_restoring``), a constant moment (it only moves the equilibrium, which
#: each run fits), terms of time, inertia or timing (a pendulum has no drive and no
#: release delay to fit).
CANDIDATES: tuple[str, ...] = tuple(
    name
    for name, entry in LIBRARY.items()
    if name not in BASE_TERMS
    and entry.role == "force"
    and ((entry.v_power or 0) >= 1 or entry.set_valued_at_rest)
)
SETUP = Setup(PIVOT_DOF, terms=BASE_TERMS)
#: The identified inertia's name in the equation and in the pendulum's result.
INERTIA, ADDED_MASS = "inertia", "added_mass"
MAX_NFEV = 200


def at_pivot(name: str) -> bool:
    """Whether the identified term ``name`` is a moment of the pivot (its force does not
    grow with speed), not the vehicle's force at lever arm l."""
    return name != INERTIA and not (LIBRARY[name].v_power or 0) >= 1


def weight(name: str, arm: float) -> float:
    """Weight of the identified coefficient ``name`` at lever arm ``arm`` (m): l² for the
    inertia, l^(p+1) for a vehicle term of speed power p, 1 at the pivot."""
    if name == INERTIA:
        return arm**2
    if at_pivot(name):
        return 1.0
    return arm ** ((LIBRARY[name].v_power or 0) + 1)


def unit(name: str, axis: str) -> str:
    """Unit of the pendulum's coefficient ``name`` (the vehicle's along the swing ``axis``,
    or the pivot's moment)."""
    if name in (INERTIA, ADDED_MASS):
        return "kg"
    return LIBRARY[name].units[1] if at_pivot(name) else LIBRARY[name].unit(axis)


def reported(name: str) -> str:
    """The coefficient's name in the pendulum's result (the inertia is the added mass α)."""
    return ADDED_MASS if name == INERTIA else name


def record_of(run_id: str, t: np.ndarray, phi: np.ndarray, geometry: PendulumGeometry) -> Record:
    """A free-decay record of the one equation with the rig's geometry as known terms."""
    arm = geometry.pivot_to_vehicle_m
    names = (INERTIA, *BASE_TERMS, *CANDIDATES)
    return Record(
        run_id,
        np.asarray(t, dtype=float),
        np.asarray(phi, dtype=float),
        None,
        known_inertia=geometry.known_inertia(),
        known_terms={
            "sine_restoring": geometry.restoring_stiffness(),
            "linear_damping": geometry.pivot_damping_nm_s,
        },
        weights={n: weight(n, arm) for n in names},
    )


def fit_pendulum(
    records: Sequence[Record], effects: Sequence[str] = (), start: np.ndarray | None = None
) -> MotionFit:
    """Output-error fit of α, β (and ``effects``) and per record the offset (x_eq), φ₀, φ̇₀
    (``estimation.motion.fit.fit_motion``); ``start``: the full parameter vector."""
    return fit_motion(records, SETUP, effects, start=start, max_nfev=MAX_NFEV)


def swing(
    record: Record, alpha: float, beta: float, gamma: float, phi0: float
) -> tuple[np.ndarray, np.ndarray]:
    """φ − offset and φ̇ of the configured equation with fixed α, β, γ, released at rest
    from ``phi0`` (rad) at the record's first sample."""
    names = (INERTIA, *BASE_TERMS, "quadratic_damping")
    ((x, v),) = simulate(
        [record], SETUP, names, np.array([alpha, beta, gamma]), np.array([[phi0, 0.0]])
    )
    return x, v
