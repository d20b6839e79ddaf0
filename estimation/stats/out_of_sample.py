"""Leave-one-out prediction: the refits' tolerance, their budget, and what their error resolves.

A leave-one-run-out (tow, spin) or leave-one-record-out (decay, pendulum) check refits the
shared coefficients on all runs but one, predicts the one left out and pools the squared
errors over the folds. Both kinds judge the pooled RMSE by one rule (``loro_dropped``), so
the refits' tolerance and budget are declared here once.
"""

from __future__ import annotations

import numpy as np

#: least_squares' xtol, ftol and gtol of every tow/spin fit and of every leave-one-out refit
#: (of every kind): a fit stops when a step changes the parameters or the cost by less than
#: this relative amount, so what it returns is known to about this much and no better.
REFIT_TOLERANCE = 1e-10
#: Function evaluations of one leave-one-out refit: each starts at the all-runs optimum, a
#: small step away.
LORO_NFEV = 40
#: The fewest runs (records) a leave-one-out check is formed from: with two, each fold fits
#: one run and predicts the other, which says nothing about the shared coefficients' transfer.
LORO_MIN_RUNS = 3

#: Relative resolution of a leave-one-out RMSE: √``REFIT_TOLERANCE``. Each refit stops
#: when the cost S changes by less than ftol·S; S is quadratic in the parameters' error δθ
#: near the optimum, so δθ is only pinned to where ½δθᵀHδθ ≈ ftol·S, and a held-out run's
#: residual (not at its own minimum) moves linearly with δθ: its RMSE is known to about
#: √(2·ftol) ≈ √ftol of itself. (Measured: a friction held at its bound 0 predicts exactly as
#: the model without it; their two leave-one-run-out RMSEs differed by 9e-8 of themselves.)
LORO_RESOLUTION = float(np.sqrt(REFIT_TOLERANCE))


def loro_dropped(cv_new: float, cv_bar: float) -> bool:
    """Whether the leave-one-out RMSE ``cv_new`` is below ``cv_bar`` by more than the
    refits resolve (``LORO_RESOLUTION`` of it). A smaller difference says only where the
    refits stopped: a candidate whose coefficient is ~0 predicts as the model without it,
    the two RMSEs agree to round-off, and a bare ``<`` decided the verdict at random."""
    return cv_new < cv_bar * (1.0 - LORO_RESOLUTION)


def pooled_rmse(held_out: list[np.ndarray]) -> float:
    """√(Σ_folds Σ_samples r² / Σ_folds n): the folds' held-out residuals pooled (m or rad)."""
    sq = sum(float(r @ r) for r in held_out)
    return float(np.sqrt(sq / sum(r.size for r in held_out)))
