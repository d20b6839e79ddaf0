"""The RK4 step of the tow/spin simulator: the sample step of a per-sample drive (else
``RK4_MAX_STEP_S``), halved until it resolves every parameter set's period and damping rate
(``motion.equation.stable_step``), at most ``MAX_HALVINGS`` times."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from estimation.axis.prepared_run import PreparedRun
from estimation.motion.equation import range_rates, stable_step
from estimation.motion.terms import TermValues

RK4_MAX_STEP_S = 0.1  # RK4 error < 1e-6 m on BENBAM-like dynamics (τ ≥ 0.5 s)
#: Most halvings of that step (or of a driven record's sample step) ``integration_step``
#: takes: a parameter set whose fastest rate needs more than 2⁴ = 16 steps per sample
#: (h·c/M ≤ 0.5: it settles within 1/8 of a sample) is one no sampled record resolves,
#: far from the data; the divergence guard (``bounded``) turns its trial into a large
#: misfit instead. (64 steps per sample left the ship2d fit on the limit as well, at 4×
#: the time.)
MAX_HALVINGS = 4


class StepParameters(Protocol):
    """What the step reads of S parameter sets (``axis.model.ParamView``): the matrix,
    shape (S, G), its force terms and the total inertia of each set on a run."""

    @property
    def theta(self) -> np.ndarray: ...

    @property
    def forces(self) -> Sequence[TermValues]: ...

    def total_inertia(self, run: PreparedRun) -> np.ndarray:
        """M + M_drive + Σ θ_i·w_i per parameter set (kg or kg·m²), shape (S,)."""
        ...


def _local_rates(p: StepParameters, run: PreparedRun) -> tuple[np.ndarray, np.ndarray]:
    """The force terms' largest stiffness and damping over the run's range (its peak
    excursion and speed, ``motion.equation.range_rates``), per parameter set, each (S,)."""
    sets = p.theta.shape[0]
    forces = [(c.term, np.broadcast_to(c.value, (sets, 1))[:, 0]) for c in p.forces]
    stiffness, damping = range_rates(forces, run.peak_excursion, run.peak_speed)
    return np.broadcast_to(stiffness, (sets,)), np.broadcast_to(damping, (sets,))


def coarsest_step(runs: Sequence[PreparedRun]) -> float:
    """``RK4_MAX_STEP_S``, or the sample step of a per-sample drive (s)."""
    base = RK4_MAX_STEP_S
    if any(r.constant_drive is None for r in runs):  # one step per held thrust sample
        base = min(base, min(float(np.median(np.diff(r.t))) for r in runs if r.t.size > 1))
    return base


def integration_step(p: StepParameters, runs: Sequence[PreparedRun]) -> tuple[float, np.ndarray]:
    """The RK4 step (s) for the parameter sets of ``p`` on ``runs``, and which sets it cannot
    resolve (bool, (S,)).

    ``RK4_MAX_STEP_S``, or the sample step of a per-sample drive (one step per held value),
    halved until it resolves each set's natural period and damping rate on each run
    (``motion.equation.stable_step`` on the forces linearised over the run's range,
    ``_local_rates``): h·c/M ≤ 0.5, inside RK4's real-axis stability limit ≈ 2.785. Halving
    keeps the step of a set that moves slightly (a finite-difference Jacobian's sets share
    it). A set needing more than ``MAX_HALVINGS`` halvings is not integrated (a diverged
    trial), never with an unstable step. With the sample step alone the ship2d record's
    fit sat at K_Q ≈ 1930 N·s²/m², h·c/M ≈ 4.7 at the model's peak speed."""
    base = coarsest_step(runs)
    needed = np.full(p.theta.shape[0], base)
    for r in runs:
        stiffness, damping = _local_rates(p, r)
        for i, (m, k, c) in enumerate(zip(p.total_inertia(r), stiffness, damping, strict=True)):
            needed[i] = min(needed[i], stable_step(base, float(m), float(k), float(c), False))
    floor = base / 2**MAX_HALVINGS
    unresolved = ~(needed >= floor)  # NaN rates (a trial of NaN) count as unresolved
    finest = float(np.min(needed[~unresolved], initial=base))
    return base / 2 ** int(np.ceil(np.log2(base / finest) - 1e-9)), unresolved
