"""The RK4 loop of ``equation.py`` compiled (numba): the same arithmetic, in the same order.

An estimate integrates the equation a few hundred times over hundreds of steps, each on a
handful of states (parameter sets × records): in NumPy every step is ~60 array operations
on arrays of ten numbers, and their dispatch, not the arithmetic, was 80 % of the CPU of a
decay search. Compiled, a step costs ~0.07 µs per state (4 RK4 stages of a few terms).

A force term enters as ``c·X(x)·V(v)``: a constant and two basis functions chosen by code
(``kernel.X_BASIS``, ``kernel.V_BASIS``; ``kernel.form_of`` reads them off the term's own
regressor, so the physics stays in the library entry). Each force evaluation forms every
basis function once into a small scratch array (``_fill_basis``; the costly ones, x³, sin x,
v³ and sign v, only when a term uses them) and each term reads its two by index: choosing
them by code per term (a chain of branches for each of T terms, four times a step) cost
more than the arithmetic — a pendulum's 32 sets × 601 steps took 2.97 ms, now 1.36 ms, the
same bits. Each state steps by RK4 with the
drive held over the step; dry friction (the set-valued terms, of size ``held``; ``dry``:
there are some) is constant through a step, and the step is split where the velocity
reverses (``equation.py``'s module doc).

Guard: every ``freeze_every`` steps and at the last, a diverged state (non-finite, or
beyond ``limit`` of its record) is held at the limit (``equation.integrate``).

numba is imported with this module, which ``kernel.step_grid`` loads on the first
integration that runs compiled (importing numba costs ~0.3 s of CPU: a command that does
not estimate, or integrates only a few short grids, ``kernel.LOOP``, never pays it).
The compiled code is cached beside the source (``cache=True``): only the first process
after a change compiles it (7–10 s of CPU on this 2-core box); later ones load it in ~0.5 s.
The helpers that take the term arrays are inlined by numba (``inline="always"``), and so is
the RK4 step in the loop of smooth terms (a quarter of its time was the call: the 32 sets
1.36 -> 1.02 ms); the friction step calls it where it meets a reversal, four calls not
inlined (inlining them too doubled the compile, to 17 s of CPU).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _sign(a: float) -> float:
    """np.sign of a float: ±1, 0, or NaN for NaN."""
    if a > 0.0:
        return 1.0
    if a < 0.0:
        return -1.0
    return a  # 0.0, -0.0 or NaN


#: Where ``_fill_basis`` puts X(x) of code c (``kernel.X_BASIS``: 1, x, x², x³, sin x) and
#: V(v) of code c (``kernel.V_BASIS``: 1, v, |v|, |v|·v, v², v³, sign v): X at c, V at
#: ``V_AT`` + c.
V_AT = 5
BASIS_SIZE = 12


@njit(cache=True, inline="always")
def _fill_basis(x, v, basis, need):
    """Every basis function at (x, v) into ``basis`` (``V_AT``), in the arithmetic of
    ``kernel.X_BASIS``/``V_BASIS``; x³, sin x, v³ and sign v only where a term uses them
    (``need``, the same for every state and step: their slots are then never read).
    Cubes are products, not ``pow``: a ``pow`` call was most of a cubic term's step (~50 ns
    against ~1 ns)."""
    need_x3, need_sin, need_v3, need_sign = need
    basis[0] = 1.0
    basis[1] = x
    basis[2] = x * x
    if need_x3:
        basis[3] = x * x * x
    if need_sin:
        basis[4] = math.sin(x)
    basis[V_AT] = 1.0
    basis[V_AT + 1] = v
    basis[V_AT + 2] = abs(v)
    basis[V_AT + 3] = abs(v) * v
    basis[V_AT + 4] = v * v
    if need_v3:
        basis[V_AT + 5] = v * v * v
    if need_sign:
        basis[V_AT + 6] = _sign(v)


# ``ctx``: one state's scalars (drive held over the step in N or N·m, 1/inertia, |F_c|, and
# the state's row s and column r in ``coef``); ``coef`` (T, S, R), ``scale``, ``xcode``,
# ``vcode`` (T,): the single-valued terms, φ_j = scale_j·X(x)·V(v); ``basis``, ``need``:
# ``_fill_basis``'s scratch and which of its costly functions the terms use.


@njit(cache=True, inline="always")
def _force(x, v, ctx, coef, scale, xcode, vcode, basis, need):
    """The drive plus every single-valued term's force at (x, v), summed in term order:
    the basis functions are formed once (``_fill_basis``) and each term reads its two."""
    drive, _, _, s, r = ctx
    _fill_basis(x, v, basis, need)
    net = drive
    for j in range(scale.size):
        net = net + coef[j, s, r] * (scale[j] * basis[xcode[j]] * basis[V_AT + vcode[j]])
    return net


def _rk4_step(x, v, h, friction, ctx, coef, scale, xcode, vcode, basis, need):
    """One RK4 step of length ``h`` from (x, v), the friction force ``friction``
    (−F_c·direction) held through it."""
    inv = ctx[1]
    half = 0.5 * h
    a1 = (_force(x, v, ctx, coef, scale, xcode, vcode, basis, need) + friction) * inv
    v2 = v + half * a1
    a2 = (_force(x + half * v, v2, ctx, coef, scale, xcode, vcode, basis, need) + friction) * inv
    v3 = v + half * a2
    a3 = (_force(x + half * v2, v3, ctx, coef, scale, xcode, vcode, basis, need) + friction) * inv
    a4 = (
        _force(x + h * v3, v + h * a3, ctx, coef, scale, xcode, vcode, basis, need) + friction
    ) * inv
    return x + h * v + h * h / 6.0 * (a1 + a2 + a3), v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)


#: One RK4 step, called where a step meets dry friction (``_friction_step``: four calls,
#: each inlined would double the compile) …
_rk4 = njit(cache=True)(_rk4_step)
#: … and inlined into the loop of smooth terms, where the call was a quarter of a step.
_rk4_inlined = njit(cache=True, inline="always")(_rk4_step)


@njit(cache=True)
def _friction_step(x, v, h, ctx, coef, scale, xcode, vcode, basis, need):
    """One step with dry friction of size ``held``: stuck, moving, or split at a reversal
    of the velocity (``equation._friction_step``, per state)."""
    inv, held = ctx[1], ctx[2]
    if v == 0.0:  # at rest: it moves only where the other forces overcome the friction
        pull = _force(x, 0.0, ctx, coef, scale, xcode, vcode, basis, need)
        if abs(pull) <= held:
            return x, 0.0
        direction = _sign(pull)
    else:
        direction = _sign(v)
    f = -held * direction
    x1, v1 = _rk4(x, v, h, f, ctx, coef, scale, xcode, vcode, basis, need)
    if v1 * direction < 0:  # split at every reversal, also at F_c = 0 (equation.py)
        h1 = h * min(max(abs(v) / max(abs(v) + abs(v1), 1e-300), 0.0), 1.0)
        xa, va = _rk4(x, v, h1, f, ctx, coef, scale, xcode, vcode, basis, need)
        aa = (_force(xa, va, ctx, coef, scale, xcode, vcode, basis, need) + f) * inv
        h1 = min(max(h1 - va / (np.inf if aa == 0 else aa), 0.0), h)
        xa, _ = _rk4(x, v, h1, f, ctx, coef, scale, xcode, vcode, basis, need)
        pull = _force(xa, 0.0, ctx, coef, scale, xcode, vcode, basis, need)
        if abs(pull) <= held:
            return xa, 0.0
        return _rk4(
            xa, 0.0, h - h1, -held * _sign(pull), ctx, coef, scale, xcode, vcode, basis, need
        )
    return x1, v1


@njit(cache=True)
def integrate_grid(
    x0, v0, drive, inv, held, dry, coef, scale, xcode, vcode, h, limit, freeze_every, xs, vs,
):  # fmt: skip
    """Fill the step grid ``xs``/``vs`` (K, S, R) from the states (x0, v0) (S, R) under the
    per-step drive (K − 1, S, R); returns whether a diverged state was frozen (module doc).

    ``coef`` (T, S, R) with ``scale``/``xcode``/``vcode`` (T,): the single-valued terms;
    ``inv`` (S, R): 1/inertia; ``held`` (S, R): |F_c| of the set-valued terms."""
    n_steps, n_sets, n_tracks = xs.shape
    x = x0.copy()
    v = v0.copy()
    xs[0] = x
    vs[0] = v
    frozen = np.zeros((n_sets, n_tracks), dtype=np.bool_)
    any_frozen = False
    basis = np.zeros(BASIS_SIZE)
    need_x3 = need_sin = need_v3 = need_sign = False
    for j in range(scale.size):
        need_x3 = need_x3 or xcode[j] == 3
        need_sin = need_sin or xcode[j] == 4
        need_v3 = need_v3 or vcode[j] == 5
        need_sign = need_sign or vcode[j] == 6
    need = (need_x3, need_sin, need_v3, need_sign)
    for k in range(1, n_steps):
        for s in range(n_sets):
            for r in range(n_tracks):
                ctx = (drive[k - 1, s, r], inv[s, r], held[s, r], s, r)
                if dry:
                    x[s, r], v[s, r] = _friction_step(
                        x[s, r], v[s, r], h, ctx, coef, scale, xcode, vcode, basis, need
                    )
                else:
                    x[s, r], v[s, r] = _rk4_inlined(
                        x[s, r], v[s, r], h, 0.0, ctx, coef, scale, xcode, vcode, basis, need
                    )
        if k % freeze_every == 0 or k == n_steps - 1:
            bad = False
            for s in range(n_sets):
                for r in range(n_tracks):
                    ok = np.isfinite(x[s, r]) and np.isfinite(v[s, r])
                    if not (ok and abs(x[s, r]) < limit[r]):
                        frozen[s, r] = bad = any_frozen = True
            if bad:  # a diverged trial: held at the limit from here on
                for s in range(n_sets):
                    for r in range(n_tracks):
                        if frozen[s, r]:
                            x[s, r] = _held_at_limit(x[s, r], limit[r])
                            v[s, r] = 0.0
        xs[k] = x
        vs[k] = v
    return any_frozen


@njit(cache=True)
def _held_at_limit(x: float, limit: float) -> float:
    """np.clip(np.nan_to_num(x), −limit, limit)."""
    if np.isnan(x):
        return 0.0
    return min(max(x, -limit), limit)


@njit(cache=True)
def hermite(grid_x, grid_v, h, tau):
    """``equation.hermite`` compiled: the same arithmetic in the same order, per sample
    (grid arrays (K, S); ``tau`` (S, n) or (1, n)); returns x and ẋ, each (S, n)."""
    n_sets = grid_x.shape[1]
    rows, n = tau.shape
    k_max = grid_x.shape[0] - 2
    x = np.empty((n_sets, n))
    v = np.empty((n_sets, n))
    for c in range(n_sets):
        row = c if rows > 1 else 0
        for i in range(n):
            at = tau[row, i] / h
            k = min(max(int(np.floor(at)), 0), k_max)
            s = min(max(tau[row, i] / h - k, 0.0), 1.0)
            x0, x1 = grid_x[k, c], grid_x[k + 1, c]
            v0, v1 = grid_v[k, c] * h, grid_v[k + 1, c] * h
            s2, s3 = s * s, s * s * s
            xi = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * x1
            x[c, i] = xi + (s3 - s2) * v1
            vi = ((6 * s2 - 6 * s) * x0 + (3 * s2 - 4 * s + 1) * v0 + (6 * s - 6 * s2) * x1) / h
            v[c, i] = vi + (3 * s2 - 2 * s) * v1 / h
    return x, v
