"""Where a trial of a set-valued term (dry friction) starts: a profile.

A set-valued term (dry friction) starts from a **profile**: the candidate held at ``PROFILE``
× its linearised value (one Gauss–Newton step from the current fit; a decade each side), the
model's own parameters moved by ``PROFILE_STEPS`` chord steps (Gauss–Newton with the current
fit's Jacobian), all grid points in one vectorized simulation per step; the lowest simulated
SSE wins. Dry friction's effect is far from linear in its coefficient (it sets where the
swing stops, and the equilibrium moves with it): from the linearised value it starts in the
wrong basin — on a pendulum released from two amplitudes the linearised F_c (0.14 N·m)
converges to 0.25 N·m at 120× the noise, the profile's to the true 0.40.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.motion.output_error_fit import MotionFit, parameters_of, simulate
from estimation.motion.records import Record, Setup, known_inertia_of
from estimation.motion.terms import LIBRARY

PROFILE = np.geomspace(0.1, 10.0, 21)  # trial starts, × the linearised value (1 included)
PROFILE_STEPS = 4  # chord (fixed-Jacobian Gauss–Newton) steps of the model's own parameters


def extend(fit: MotionFit, term_start: float) -> np.ndarray:
    """``fit``'s parameters with one more coefficient (at ``term_start``) after its globals."""
    p = parameters_of(fit)
    k = len(fit.values)
    return np.concatenate([p[:k], [term_start], p[k:]])


def profile_start(
    records: Sequence[Record],
    setup: Setup,
    current: MotionFit,
    own: np.ndarray,
    term: str,
    linear: float,
) -> np.ndarray:
    """The trial's start (module doc, *profile*): the full parameter vector."""
    k, nr = len(current.values), len(records)
    free = np.asarray(current.free, dtype=bool)  # records whose ξ₀, ξ̇₀ are nuisances
    nf = int(np.count_nonzero(free))
    measured = np.concatenate([np.asarray(r.x, dtype=float) for r in records])
    index = np.repeat(np.arange(nr), [np.size(r.t) for r in records])
    params = np.tile(parameters_of(current), (PROFILE.size, 1))  # (grid, p)
    values = linear * PROFILE
    low = np.array(
        [
            max(-known_inertia_of(r, setup) / r.weight(n) for r in records)
            if n == "inertia"
            else LIBRARY[n].lower
            for n in current.names
        ]
    )
    high = np.array([np.inf if n == "inertia" else LIBRARY[n].upper for n in current.names])
    best_sse, best = np.full(PROFILE.size, np.inf), params.copy()
    solve = np.linalg.pinv(own)  # one SVD for every chord step (lstsq per step: 70 ms each)
    for _ in range(PROFILE_STEPS + 1):  # chord steps: the current fit's Jacobian throughout
        initial = np.zeros((PROFILE.size, nr, 2))  # a record at rest ignores its own
        initial[:, free, 0] = params[:, k + nr : k + nr + nf]
        initial[:, free, 1] = params[:, k + nr + nf :]
        sims = simulate(
            records,
            setup,
            (*current.names, term),
            np.column_stack([params[:, :k], values]),
            initial,
        )
        model = np.concatenate([x for x, _ in sims], axis=1) + params[:, k + index]
        left = measured[None, :] - model
        inside = np.all((params[:, :k] > low) & (params[:, :k] <= high), axis=1)
        inside &= np.isfinite(left).all(axis=1)
        sse = np.where(inside, np.sum(np.where(inside[:, None], left, 0.0) ** 2, axis=1), np.inf)
        better = sse < best_sse
        best_sse, best[better] = np.where(better, sse, best_sse), params[better]
        # a chord that left the bounds stops there (its best is kept)
        params = np.where(inside[:, None], params + (solve @ np.nan_to_num(left).T).T, params)
    # each grid point's best simulated state of its chord; the linearised start (factor 1,
    # before any step) is among them, so the profile never starts worse than it
    i = int(np.argmin(best_sse))
    return np.concatenate([best[i, :k], [values[i]], best[i, k:]])
