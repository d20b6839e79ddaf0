"""A tow or spin set as the one equation reads it (``estimation.motion.output_error_fit``):
records at rest until their release, in closed form for a constant drive when every term
allows it (``motion.constant_pull``), else by RK4.

Model (per axis, SI):  (M + M_drive + Σ θ_i·w_i)·v̇ = τ + Σ_j θ_j·φ_j(x − x_release, v),
motion starting at t_release + Σ δ (timing terms). The base is inertia M and the library
entries ``linear_damping`` (K_L) and ``quadratic_damping`` (K_Q); each effect is one more
entry (``estimation.motion.terms``) that carries its own regressor, so nothing here names
one. Parameters are evaluated for S parameter sets at once (rows of ``theta``) so Jacobians
by finite differences cost one vectorized call.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import numpy as np

from estimation.axis.prepared_run import PreparedRun
from estimation.motion import output_error_fit
from estimation.motion.fit_memo import Recent
from estimation.motion.output_error_fit import names_of
from estimation.motion.records import Record, Setup
from estimation.motion.terms import LIBRARY, TermValues

BASE_NAMES: tuple[str, ...] = ("inertia", "linear_damping", "quadratic_damping")


class ParamView:
    """A (S, G) parameter matrix read as the equation's parts: the inertia column and one
    ``TermValues`` per library entry (base damping, then effects), grouped by role."""

    def __init__(self, theta: np.ndarray, effects: Sequence[str]) -> None:
        self.theta, self.effects = theta, tuple(effects)
        self.inertia = theta[:, 0]
        entries = [LIBRARY[name] for name in (*BASE_NAMES[1:], *effects)]
        self.terms = [TermValues(t, theta[:, [i + 1]]) for i, t in enumerate(entries)]
        self.forces = [c for c in self.terms if c.term.role == "force"]
        self.inertias = [c for c in self.terms if c.term.role == "inertia"]

    def total_inertia(self, run: PreparedRun) -> np.ndarray:
        """M + M_drive + Σ θ_i·w_i per parameter set (kg or kg·m²), shape (S,)."""
        total = self.inertia + run.extra_inertia
        for c in self.inertias:
            total = total + c.value[:, 0] * run.weight_equivalent
        return total


def record_of(run: PreparedRun) -> Record:
    """The run as the one equation's fit reads it: at rest until its release, its drive
    (constant or per sample, held from the last sample before the release), the drive
    train's known inertia, an undeclared hung weight's |τ|/g, its encoder step."""
    return Record(
        run.run_id,
        run.t,
        run.x,
        run.drive if run.constant_drive is None else run.constant_drive,
        known_inertia=run.extra_inertia,
        released_at=run.t_release,
        drive_before=run.drive_at_release,
        hung_weight=run.weight_equivalent,
        quantum=run.encoder_step,
    )


#: The records of the last few run sets, by identity: the term-separation module keeps its
#: sensitivities per records object, so one run set must give one records object.
_RECORDS: Recent[tuple[Record, ...]] = Recent(size=8)


def records_of(runs: Sequence[PreparedRun]) -> tuple[Record, ...]:
    """``record_of`` of every run, the same tuple again for the same ``runs`` object."""
    return _RECORDS.get((runs,), lambda: tuple(record_of(r) for r in runs))


def setup_of(runs: Sequence[PreparedRun]) -> Setup:
    """The equation of a tow or spin set: the whole inertia and the base damping identified,
    nothing known but each run's drive train (one object per DOF)."""
    return _setup(runs[0].dof if runs else "surge")


@cache
def _setup(dof: str) -> Setup:
    return Setup(dof=dof, terms=BASE_NAMES[1:])


def at_step_limit(values: np.ndarray, effects: Sequence[str], runs: Sequence[PreparedRun]) -> bool:
    """Whether ``values`` need the one integrator's finest step or nearly
    (``motion.output_error_fit.at_step_limit``): a fit there may rest on it, not on the data."""
    setup = setup_of(runs)
    return output_error_fit.at_step_limit(
        records_of(runs), setup, names_of(setup, effects), np.atleast_2d(values)
    )


def step_of(
    theta: np.ndarray, effects: Sequence[str], runs: Sequence[PreparedRun]
) -> tuple[float | None, np.ndarray]:
    """The one integrator's RK4 step (s; None: the closed form, no step) for the parameter
    sets ``theta`` (S, G) on ``runs``, and which sets it cannot resolve."""
    setup = setup_of(runs)
    return output_error_fit.step_of(
        records_of(runs), setup, names_of(setup, effects), np.atleast_2d(theta)
    )


def simulate(
    theta: np.ndarray,
    effects: Sequence[str],
    runs: Sequence[PreparedRun],
    rows: slice = slice(None),
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Displacement from the release position and velocity, per run, shape (S, n_samples),
    by the one equation (``motion.output_error_fit.simulate``: in closed form for a
    constant pull when every term allows it).

    ``theta`` has one row per parameter set: inertia, K_L, K_Q, then one column per effect.
    ``rows``: simulate only the sets ``theta[rows]``, on the RK4 step all the sets of
    ``theta`` share (a finite-difference Jacobian's perturbed sets after its centre: the
    same numbers as simulating them all at once).
    """
    setup = setup_of(runs)
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    return output_error_fit.simulate(
        records_of(runs), setup, names_of(setup, effects), theta, rows=rows
    )
