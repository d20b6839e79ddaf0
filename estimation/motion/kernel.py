"""The compiled RK4 loop's entry (``compiled.py``): each term's form, and the arrays.

The compiled loop evaluates a force term as φ(x, ẋ) = c·X(x)·V(ẋ), a constant and two
basis functions chosen by code, so that the library entry stays the one place where a
term's physics is written: its form is *read off its own regressor* here, by evaluating
φ on a grid of states and matching it to every pair of basis functions. A term whose
regressor matches none (or is not a function of (x, ẋ) alone) has no form: the integrator
then runs the NumPy loop for records that carry it — the same result, only slower.

Loading the compiled loop costs a process ~0.6 s of CPU (importing numba ~0.25 s, its first
dispatch ~0.35 s: the cached machine code installs numba's lowering registries), while the
NumPy loop costs ~50–120 µs a step, its dispatch: an estimate that integrates little (a tow
from rest is in closed form and integrates only to screen the candidates without one: six
grids of 211 steps, 0.07 s in NumPy) steps in NumPy and never loads numba (``LOOP``, an
``estimation.loop_choice.LoopChoice``). The two loops agree to rounding (bit for bit on every
case of ``tests/estimation/motion/test_compiled_integrator.py`` here), so the choice moves no
answer.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from estimation.loop_choice import LoopChoice
from estimation.motion.terms import Term, TermValues

Basis = Callable[[np.ndarray], np.ndarray]

#: X(x) by code: the order of ``compiled._x_basis``.
X_BASIS: tuple[Basis, ...] = (
    np.ones_like,
    lambda x: x,
    lambda x: x * x,
    lambda x: x * x * x,
    np.sin,
)
#: V(ẋ) by code: the order of ``compiled._v_basis``.
V_BASIS: tuple[Basis, ...] = (
    np.ones_like,
    lambda v: v,
    np.abs,
    lambda v: np.abs(v) * v,
    lambda v: v * v,
    lambda v: v * v * v,
    np.sign,
)
#: States the regressor is probed at: both signs, zero, and sizes where sin x ≠ x.
_PROBE_X = np.array([-3.1, -1.7, -0.31, 0.0, 0.045, 0.45, 1.3, 2.9, 7.5])
_PROBE_V = np.array([-2.2, -0.7, -0.05, 0.0, 0.003, 0.3, 1.1, 4.0])
#: A match leaves at most this relative difference (rounding of the same arithmetic).
_MATCH = 1e-13


#: Steps a process takes in the NumPy loop, in all, before it loads the compiled one: at
#: most ~0.25 s of CPU spent before a load that turns out to be needed after all.
NUMPY_STEPS = 2000
#: A grid of more steps runs compiled from the first (a KVLCC2 decay: 1,600 steps, 110 grids;
#: ship2d: 1,116 steps, 850 grids).
NUMPY_GRID_STEPS = 500
#: The module that imports numba (``compiled.py``).
COMPILED = "estimation.motion.compiled"


#: The process's choice (``equation.integrate`` asks it before each grid and counts the
#: grids it steps in NumPy): module doc.
LOOP = LoopChoice(COMPILED, NUMPY_STEPS, NUMPY_GRID_STEPS)


@dataclass(frozen=True)
class Form:
    """φ(x, ẋ) = ``scale``·X_BASIS[x_code](x)·V_BASIS[v_code](ẋ)."""

    scale: float
    x_code: int
    v_code: int


@lru_cache(maxsize=64)
def form_of(term: Term) -> Form | None:
    """The compiled form of ``term``'s regressor, or None when it has none (module doc)."""
    x, v = np.meshgrid(_PROBE_X, _PROBE_V, indexing="ij")
    try:
        with np.errstate(all="ignore"):
            phi = np.broadcast_to(np.asarray(term.phi(x, v), dtype=float), x.shape)
    except (TypeError, ValueError, ArithmeticError):
        return None
    if not np.all(np.isfinite(phi)):
        return None
    for x_code, bx in enumerate(X_BASIS):
        for v_code, bv in enumerate(V_BASIS):
            basis = bx(x) * bv(v)
            at = np.flatnonzero(basis)
            if at.size == 0:
                continue
            scale = float(phi.flat[at[0]] / basis.flat[at[0]])
            if np.all(np.abs(phi - scale * basis) <= _MATCH * np.maximum(np.abs(phi), 1.0)):
                return Form(scale, x_code, v_code)
    return None


def forms_of(terms: Sequence[Term]) -> list[Form] | None:
    """Every term's form, or None when one has none."""
    forms = [form_of(t) for t in terms]
    return None if any(f is None for f in forms) else [f for f in forms if f is not None]


def _per_state(value: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, dtype=float), shape)


def _plain(value: object) -> np.ndarray:
    """A writable C-ordered float array (a copy only when needed): numba compiles one
    machine-code version per argument type, and a read-only view (``np.broadcast_to``) is
    another type than a writable array, so every call passes the one type
    ``warm_up`` compiles."""
    return np.require(np.asarray(value, dtype=float), requirements=["C", "W"])


def step_grid(
    x0: np.ndarray,
    v0: np.ndarray,
    drive: np.ndarray,
    inv_inertia: np.ndarray,
    forces: Sequence[TermValues],
    h: float,
    n_steps: int,
    limit: np.ndarray,
    freeze_every: int,
) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """The states (K, S, R) on the step grid by the compiled loop, and whether a diverged
    state was frozen; None when a term has no compiled form (the caller steps in NumPy).

    ``x0``/``v0``/``inv_inertia`` (S, R); ``drive`` broadcasts to (K − 1, S, R) (the force
    held over each step); ``forces``: the force terms in the order they are summed (the
    set-valued ones are dry friction, stepped exactly: ``equation.py``); ``limit`` (R,):
    where a state counts as diverged (checked every ``freeze_every`` steps)."""
    shape = np.shape(x0)
    smooth = [c for c in forces if not c.term.set_valued_at_rest]
    forms = forms_of([c.term for c in smooth])
    if forms is None:
        return None
    from estimation.motion import compiled  # numba: loaded by the first integration only

    dry = [c for c in forces if c.term.set_valued_at_rest]
    held = np.zeros(shape)
    for c in dry:
        held = held + _per_state(c.value, shape)
    coef = np.empty((len(smooth), *shape))
    for j, c in enumerate(smooth):
        coef[j] = _per_state(c.value, shape)
    xs, vs = np.empty((n_steps, *shape)), np.empty((n_steps, *shape))
    frozen = compiled.integrate_grid(
        _plain(x0),
        _plain(v0),
        _plain(np.broadcast_to(drive, (n_steps - 1, *shape))),
        _plain(_per_state(inv_inertia, shape)),
        _plain(np.abs(held)),
        bool(dry),
        coef,
        _plain([f.scale for f in forms]),
        np.array([f.x_code for f in forms], dtype=np.int64),
        np.array([f.v_code for f in forms], dtype=np.int64),
        float(h),
        _plain(limit),
        int(freeze_every),
        xs,
        vs,
    )
    return xs, vs, bool(frozen)


def hermite(
    grid_x: np.ndarray, grid_v: np.ndarray, h: float, tau: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """``equation.hermite`` (the samples read off a step grid) by the compiled loop, the
    same numbers: for a grid ``step_grid`` made (the compiled module is then loaded). The
    arrays are passed C-ordered, the one argument type ``warm_up`` compiles."""
    from estimation.motion import compiled

    return compiled.hermite(
        np.ascontiguousarray(grid_x, dtype=float),
        np.ascontiguousarray(grid_v, dtype=float),
        float(h),
        np.ascontiguousarray(tau, dtype=float),
    )
