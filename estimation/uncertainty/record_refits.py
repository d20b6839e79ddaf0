"""How a free decay's or a pendulum swing's records are re-fitted for the uncertainty budget
(``uncertainty.budget``'s ``Refits``): the equation's setup with a given input moved, a
repeat campaign alone.

Their Type B inputs are what the estimate was given as known — the linear ``stiffness``
(ρ·g·A_w, Δ·g·GM) and the ``known_inertia`` — with a half-width declared at import. They
are constants of the model, not of the records (``DeclaredInput.moves_records`` False): a
free decay scales every coefficient alike, so a stiffness known to 1 % makes every
identified coefficient uncertain by about 1 % whatever the record, and leaves T₀ and ζ where
they were.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from estimation.kind_advice import advice_for
from estimation.motion.equivalent import equivalent_damping
from estimation.motion.estimation_result import EstimationResult
from estimation.motion.output_error_fit import MotionFit, fit_motion, parameters_of
from estimation.motion.records import Setup, known_terms_of
from estimation.motion.term_search import TRIAL_NFEV
from estimation.motion.terms import DOFS
from estimation.motion.well_determined import (
    Combination,
    decay_combinations,
    inertia_and_stiffness,
)
from estimation.uncertainty.budget import DeclaredInput
from estimation.uncertainty.rows import BudgetRow

#: The inputs of a decay a tolerance can be declared for: (meaning, unit on a
#: translational DOF, on a rotational one).
DECLARABLE: dict[str, tuple[str, str, str]] = {
    "stiffness": ("the given linear restoring stiffness", "N/m", "N·m/rad"),
    "known_inertia": ("the given mass or inertia of the body", "kg", "kg·m²"),
}
NOT_DECLARED = (
    "Type B not declared: the stiffness and known inertia are taken as exact, so U covers the "
    f"fit alone ({advice_for('decay').declare_tolerances})"
)


def _moved(setup: Setup, source: str, delta: float) -> Setup | None:
    """``setup`` with the declared input ``source`` moved by ``delta`` (None: not given)."""
    if source == "stiffness":
        known = dict(setup.known_terms)
        if "restoring_spring" not in known:
            return None
        known["restoring_spring"] += delta
        return replace(setup, known_terms=known)
    return replace(setup, known_inertia=setup.known_inertia + delta)


class RecordRefits:
    """The re-fits of a result of the one motion engine (a free decay, a pendulum swing):
    its records and setup as fitted. ``kind``: the advice's kind; ``not_declared``: the
    note when nothing is declared (a pendulum's says its geometry is taken as exact)."""

    def __init__(
        self,
        result: EstimationResult[Any],
        kind: str = "decay",
        not_declared: str = NOT_DECLARED,
    ) -> None:
        fit, setup = result.fit_after, result.setup
        if fit is None or setup is None:
            raise ValueError("result: got an estimate without its fit, allowed: a fitted decay")
        self.result, self.fit, self.setup = result, fit, setup
        self.kind, self.not_declared = kind, not_declared

    def inputs(
        self, tolerances: Mapping[str, float]
    ) -> tuple[dict[str, float], list[DeclaredInput], list[str]]:
        """``tolerances`` by ``DECLARABLE`` name, checked; a zero half-width declares
        nothing; an input the estimate was not given is named among the others."""
        rotational = DOFS[self.setup.dof]
        declared, inputs, idle = {}, [], []
        for name, half_width in tolerances.items():
            if name not in DECLARABLE:
                raise ValueError(f"tolerances.{name}: unknown, allowed: {', '.join(DECLARABLE)}")
            if not (math.isfinite(half_width) and half_width >= 0):
                raise ValueError(f"tolerances.{name}: got {half_width!r}, allowed: a finite ≥ 0")
            if half_width == 0:
                continue
            declared[name] = float(half_width)
            meaning, unit_t, unit_r = DECLARABLE[name]
            unit = unit_r if rotational else unit_t
            if _moved(self.setup, name, 0.0) is None:
                idle.append(f"{name} (±{half_width:g} {unit}: {meaning}; not given)")
                continue
            inputs.append(DeclaredInput(name, half_width, unit, meaning, moves_records=False))
        return declared, inputs, idle

    def moved(
        self, declared: DeclaredInput, delta: float, part: int
    ) -> tuple[MotionFit, tuple[Combination, ...]]:
        setup = _moved(self.setup, declared.name, delta)
        assert setup is not None, declared.name  # inputs() named an input not given as idle
        fit = self._refit(setup, list(range(len(self.result.records))))
        return fit, self.combinations(fit, setup)

    def combinations(self, fit: MotionFit, setup: Setup | None = None) -> tuple[Combination, ...]:
        """The result's combinations on ``fit``, with ``setup`` (the result's own when None)
        at the result's swing amplitudes."""
        setup = setup or self.setup
        first = self.result.records[0]
        total, k = inertia_and_stiffness(setup, first, fit)
        if not (total > 0 and k > 0):
            return ()
        omega = float(np.sqrt(k / total))
        known = known_terms_of(first, setup)
        equivalent = [
            equivalent_damping(fit, known, setup.dof, e.amplitude, omega, first.weights)
            for e in self.result.equivalent
        ]
        return decay_combinations(setup, first, fit, equivalent)

    def campaign(self, run_ids: Sequence[str]) -> MotionFit:
        index = {r.run_id: i for i, r in enumerate(self.result.records)}
        return self._refit(self.setup, [index[i] for i in run_ids if i in index])

    def own_rows(self, name: str, unit: str) -> list[BudgetRow]:
        """None: a free record has no drive of its own to be uncertain."""
        return []

    def _refit(self, setup: Setup, members: list[int]) -> MotionFit:
        return fit_motion(
            [self.result.records[i] for i in members],
            setup,
            self.fit.effects,
            start=parameters_of(self.fit, members),
            max_nfev=TRIAL_NFEV,
        )
