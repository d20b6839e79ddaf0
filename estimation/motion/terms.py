"""The term library of the one single-degree-of-freedom equation of motion.

Every record (tow, spin, pendulum, free decay of any DOF) is a configuration of

    (M + M_known + Σ_i θ_i·w_i)·ẍ = drive(t) + Σ_j θ_j·φ_j(x, ẋ) + Σ_l θ_l·φ_l(t)

with x the displacement from the equilibrium (m or rad), M the identified inertia (kg or
kg·m²), M_known what the rig adds (pulley, drum, hung weight, pendulum rod), w_i the weight
of an inertia term, θ_j the coefficient of a force term and φ_j its regressor (the force per
unit coefficient, N or N·m per unit; its sign says which way it acts, so a passive damping
has θ ≥ 0 and φ = −ẋ; a term of time φ_l(t), t from the record's first fitted sample, acts
whatever the motion). An **entry** carries all of one term's physics: its regressor and
the regressor's partial derivatives (the term's stiffness ∂f/∂x and damping ∂f/∂ẋ, used to
turn a position residual into a force residual), its bounds and physical constraints, how
its typical size follows from a record, its start value, what separates it from its
look-alikes and its report text. Model, fit, search, collinearity and diagnostics iterate
over entries; none of them names one.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

#: Degrees of freedom a record may move in, and whether each is a rotation.
DOFS: dict[str, bool] = {
    "surge": False,
    "sway": False,
    "heave": False,
    "roll": True,
    "pitch": True,
    "yaw": True,
}


def force_unit(dof: str) -> str:
    """Unit of a force or drive on ``dof``: N, or N·m on a rotation."""
    return "N·m" if DOFS.get(dof, False) else "N"


EQUIVALENT_SAMPLES = 4096  # phases per cycle of ``Term.equivalent_damping`` (midpoint rule)
#: cos and sin of those phases: the same for every term, amplitude and frequency (formed
#: once: they were two thirds of each evaluation's CPU)
_PHASE = (np.arange(EQUIVALENT_SAMPLES) + 0.5) * (2 * np.pi / EQUIVALENT_SAMPLES)
_COS_PHASE, _SIN_PHASE = np.cos(_PHASE), np.sin(_PHASE)
_COS_PHASE.flags.writeable = _SIN_PHASE.flags.writeable = False
STANDARD_GRAVITY = 9.80665  # m/s², scales the drive_inertia term (k·|τ|/g)

Regressor = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _zero(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.zeros(np.broadcast(x, v).shape)


@dataclass(frozen=True)
class Term:
    """One entry of the library (see the module doc).

    ``role``: "force" (θ·φ(x, ẋ) on the right-hand side), "inertia" (θ·w added to the
    inertia: the force −θ·w·ẍ), "time" (θ·φ(τ) on the right-hand side, τ the time from
    the record's first fitted sample in s: a force that changes along the record whatever
    the motion) or "timing" (the motion starts θ seconds late).
    ``units``: the coefficient's unit on a translational and on a rotational DOF.
    ``lower``/``upper``: hard bounds the fit keeps (a damping < 0 would make the simulation
    grow without limit); ``physical`` says why. ``start_share``: the start value as a share
    of the term's typical size (0: the term starts off); ``start_value``: an absolute one
    (a dimensionless ratio known a priori). ``v_power``/``x_power``: the
    regressor's degree in ẋ and x near rest (0 with ``sign_of_v``: a force that only flips with the
    direction of motion; None: does not depend on it), used to tell when the closed form of
    a constant-force tow applies. ``set_valued_at_rest``: at ẋ = 0 the force takes any value
    up to |θ| that holds the body (dry friction). ``separated_by``: the run that tells the
    term from its rivals on a driven record (a tow, a spin); ``separated_in_decay``: on a free
    decay, where no force can be reversed or changed (empty: the same advice).
    """

    name: str
    formula: str
    units: tuple[str, str]
    signature: str
    separated_by: str
    role: str = "force"
    phi: Regressor = _zero
    phi_t: Callable[[np.ndarray], np.ndarray] | None = None
    dphi_dx: Regressor = _zero
    dphi_dv: Regressor = _zero
    lower: float = -np.inf
    upper: float = np.inf
    physical: str = ""
    start_share: float = 0.0
    start_value: float | None = None
    x_power: int | None = None
    v_power: int | None = None
    sign_of_v: bool = False
    separated_in_decay: str = ""
    set_valued_at_rest: bool = False

    def unit(self, dof: str) -> str:
        """Unit of the coefficient on ``dof`` (a tow is surge, a spin yaw)."""
        return self.units[1] if DOFS.get(dof, False) else self.units[0]

    def regressor(
        self,
        x: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        weight: float,
        tau: np.ndarray | None = None,
    ) -> np.ndarray:
        """Force per unit coefficient along a trajectory (N or N·m per unit) with ``tau``
        its sample times from the first (s; needed by a "time" term); timing terms have
        none (zeros)."""
        if self.role == "inertia":
            return -weight * np.asarray(a, dtype=float)
        if self.role == "timing":
            return np.zeros(np.shape(x))
        if self.role == "time":
            if tau is None or self.phi_t is None:
                raise ValueError(f"{self.name}: a time term needs the sample times (tau)")
            return self.phi_t(np.asarray(tau, dtype=float)) + np.zeros(np.shape(x))
        return self.phi(np.asarray(x, dtype=float), np.asarray(v, dtype=float))

    def largest_force(
        self,
        value: float,
        x: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        weight: float,
        tau: np.ndarray | None = None,
    ) -> float:
        """Largest |force| the term exerts along a trajectory (N or N·m; 0 for timing)."""
        reg = self.regressor(x, v, a, weight, tau)
        return abs(value) * float(np.max(np.abs(reg), initial=0.0))

    def typical(
        self,
        force: float,
        x: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        weight: float,
        tau: np.ndarray | None = None,
    ) -> float:
        """The coefficient that makes this term exert ``force`` at its largest along the
        trajectory: its natural scale on this record (timing terms: 0.1 s)."""
        if self.role == "timing":
            return 0.1
        reg = float(np.max(np.abs(self.regressor(x, v, a, weight, tau)), initial=0.0))
        return abs(force) / reg if reg > 0 else 1.0

    def start(
        self,
        force: float,
        x: np.ndarray,
        v: np.ndarray,
        a: np.ndarray,
        weight: float,
        tau: np.ndarray | None = None,
    ) -> float:
        """The coefficient a fit starts from: ``start_value`` (a dimensionless ratio known
        a priori), else ``start_share`` of the term's typical size on this record."""
        if self.start_value is not None:
            return self.start_value
        return self.start_share * self.typical(force, x, v, a, weight, tau)

    def equivalent_damping(self, amplitude: float, omega: float) -> float:
        """Equivalent linear damping per unit coefficient at ``amplitude`` (m or rad) and
        ``omega`` (rad/s): the energy the term takes out of x = a·cos ωt over one cycle,
        E = −∮ φ(x, ẋ)·ẋ dt, divided by what a unit linear damping takes, π·a²·ω
        (harmonic balance; ITTC 7.5-02-07-04.5's B_e): 1 for linear damping,
        8/(3π)·ω·a for quadratic, 3/4·ω²·a² for cubic drag, 4/(π·ω·a) for dry friction,
        0 for a restoring term and for terms that are not forces of the motion."""
        if self.role != "force" or amplitude <= 0 or omega <= 0:
            return 0.0
        x, v = amplitude * _COS_PHASE, -amplitude * omega * _SIN_PHASE
        work = float(np.mean(self.phi(x, v) * v)) * (2 * np.pi / omega)
        return -work / (np.pi * amplitude**2 * omega)

    def separation(self, free_decay: bool) -> str:
        """What tells this term apart from its rivals, on a free decay or a driven record."""
        return (self.separated_in_decay or self.separated_by) if free_decay else self.separated_by

    def in_bounds(self, value: float) -> bool:
        """Whether ``value`` lies within the hard bounds."""
        return bool(self.lower <= value <= self.upper)


@dataclass(frozen=True)
class TermValues:
    """A term with its coefficient for every parameter set, shape (S, 1), or per parameter
    set and record, shape (S, R)."""

    term: Term
    value: np.ndarray


def _sign(x: np.ndarray, v: np.ndarray) -> np.ndarray:
    return -np.sign(v)


LIBRARY: dict[str, Term] = {
    t.name: t
    for t in (
        Term(
            "linear_damping",
            "f = −B₁·ẋ",
            ("N·s/m", "N·m·s/rad"),
            "force residual proportional to velocity",
            "runs at clearly different speeds or amplitudes",
            phi=lambda x, v: -v,
            dphi_dv=lambda x, v: -np.ones(np.broadcast(x, v).shape),
            lower=0.0,
            physical="≥ 0: a passive body takes energy out of the motion",
            v_power=1,
            start_share=0.3,
            separated_in_decay=(
                "decays released from clearly different amplitudes (linear damping takes the same"
                " share of every swing, whatever its size)"
            ),
        ),
        Term(
            "quadratic_damping",
            "f = −B₂·|ẋ|·ẋ",
            ("N·s²/m²", "N·m·s²/rad²"),
            "decay faster at large amplitude or speed, slower near rest",
            "runs (or releases) at clearly different amplitudes or forces",
            phi=lambda x, v: -np.abs(v) * v,
            dphi_dv=lambda x, v: -2.0 * np.abs(v),
            lower=0.0,
            physical="≥ 0: drag opposes the motion",
            v_power=2,
            separated_in_decay=(
                "decays released from clearly different amplitudes, the largest well above this one"
            ),
        ),
        Term(
            "coulomb_friction",
            "f = −F_c·sign(ẋ) (dry friction; holds the body at rest while |net| ≤ F_c)",
            ("N", "N·m"),
            "constant force residual that flips with the direction of motion; peaks of a "
            "decay fall linearly; K_Q pushed toward 0 or negative",
            "a reverse tow/spin (opposite force) or a free-decay run",
            phi=_sign,
            lower=0.0,
            physical="≥ 0: friction opposes the motion",
            start_share=0.01,
            v_power=0,
            sign_of_v=True,
            set_valued_at_rest=True,
            separated_in_decay=(
                "a decay that runs down to small swings (dry friction's loss per half-cycle does "
                "not shrink with the amplitude), or one released from a clearly larger amplitude"
            ),
        ),
        Term(
            "constant_bias",
            "f = b (does not flip with direction: a current, a cable's pull, a sensor zero)",
            ("N", "N·m"),
            "constant force residual of the same sign both ways",
            "a reverse tow/spin (opposite force)",
            phi=lambda x, v: np.ones(np.broadcast(x, v).shape),
            v_power=0,
            separated_in_decay=(
                "a record of the body at rest before its release (on a free decay a constant "
                "force only moves the equilibrium)"
            ),
        ),
        Term(
            "drive_inertia",
            "M_app = M + k·|τ|/g (the hung weight accelerates too)",
            ("kg/kg", "m"),
            "apparent inertia that grows with the drive: transients too slow at large weights",
            "runs at clearly different weights with the hung mass declared",
            role="inertia",
            lower=0.0,
            physical="≥ 0: a hung weight adds inertia",
            start_value=0.1,
        ),
        Term(
            "restoring_spring",
            "f = −k_s·x (x from the equilibrium: the release point of a tow, the rest "
            "position of a decay; a tow's spring anchored elsewhere adds a constant_bias)",
            ("N/m", "N·m/rad"),
            "force residual proportional to position; speed sags along a run; the period of "
            "a decay",
            "a long run at small force, a static pull at two positions, or a decay",
            phi=lambda x, v: -x,
            dphi_dx=lambda x, v: -np.ones(np.broadcast(x, v).shape),
            lower=0.0,
            physical="≥ 0: a restoring force pulls back toward the equilibrium",
            x_power=1,
            separated_in_decay="a known stiffness (heave ρ·g·A_w, roll Δ·g·GM) or a known inertia",
        ),
        Term(
            "sine_restoring",
            "f = −k·sin x (gravity on a pendulum: k = m·g·l, the restoring moment per sin φ)",
            ("N/m", "N·m/rad"),
            "the period lengthens with amplitude like a pendulum's (≈ φ₀²/16 at φ₀ rad)",
            "a decay released from a clearly larger angle, or the geometry (m, l) known",
            phi=lambda x, v: -np.sin(x) + np.zeros(np.shape(v)),
            dphi_dx=lambda x, v: -np.cos(x) + np.zeros(np.shape(v)),
            lower=0.0,
            physical="≥ 0: a hanging body is pulled back down",
            x_power=1,
        ),
        Term(
            "cubic_stiffness",
            "f = −k₃·x³ (amplitude-dependent restoring: a wall-sided hull's righting arm, "
            "a mooring that stiffens)",
            ("N/m³", "N·m/rad³"),
            "the period of a decay changes with amplitude",
            "a decay released from a clearly larger offset",
            phi=lambda x, v: -(x * x * x),
            dphi_dx=lambda x, v: -3.0 * x**2,
            x_power=3,
        ),
        Term(
            "cubic_drag",
            "f = −K_C·ẋ³",
            ("N·s³/m³", "N·m·s³/rad³"),
            "steady-speed residual growing like ẋ³ (largest at the highest force)",
            "a run at a clearly higher force (e.g. 1.5× the largest), or a decay released "
            "from a clearly larger amplitude (the laws part at the highest speed)",
            phi=lambda x, v: -(v * v * v),
            dphi_dv=lambda x, v: -3.0 * v**2,
            lower=0.0,
            physical="≥ 0: drag opposes the motion",
            v_power=3,
            separated_in_decay=(
                "a decay released from a clearly larger amplitude (the laws part at the highest "
                "speed)"
            ),
        ),
        Term(
            "equilibrium_drift",
            "f = d·τ (τ from the first fitted sample: the restoring acts about an equilibrium "
            "x₀ + (d/k)·τ that drifts steadily: a heel growing with a small yaw rate, a "
            "tether paying out, a sensor's zero creeping)",
            ("N/s", "N·m/s"),
            "the mean of the oscillation moves linearly in time; the midpoints of successive "
            "extrema drift one way",
            "a decay long enough for the drift to move the mean by more than the noise, or a "
            "record of the body at rest before the release",
            role="time",
            phi_t=lambda tau: tau,
            x_power=None,
        ),
        Term(
            "release_delay",
            "motion starts at t_release + δ (brake lag, stiction)",
            ("s", "s"),
            "position residual at the start of every run, a time shift of the whole response",
            "a record with the brake signal sampled with the position",
            role="timing",
            lower=-1.0,
            upper=5.0,
        ),
    )
}


def units_of(dof: str, names: Sequence[str] = ("linear_damping", "quadratic_damping")) -> dict:
    """SI units on ``dof`` of the inertia, of the library entries ``names``, and of the
    position and velocity: the one table every result, report and page reads."""
    rotational = DOFS[dof]
    return {
        "inertia": "kg·m²" if rotational else "kg",
        **{n: LIBRARY[n].unit(dof) for n in names},
        "position": "rad" if rotational else "m",
        "velocity": "rad/s" if rotational else "m/s",
    }


def term(name: str) -> Term:
    """The library entry ``name`` (KeyError naming the library when unknown)."""
    try:
        return LIBRARY[name]
    except KeyError:
        raise KeyError(f"{name!r} is not in the term library ({', '.join(LIBRARY)})") from None
