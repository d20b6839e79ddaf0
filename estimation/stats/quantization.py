"""The position error an encoder's quantization puts into a fit, from the encoder step and
the fitted motion, and the covariance of the estimate it gives.

A record quantized to the step Q measures y = Q·round((x + u)/Q) of the true motion x, where
u ∈ [0, Q) is where the record's start happens to sit within one count: one unknown phase
per record, equally likely anywhere in the count. The error y − x = s(x + u) + u is a
sawtooth s of the *motion*, not of time: wherever the motion is slow (the start of a tow
from rest, the turning points of a swing) it is a long, slowly varying ramp, correlated
with the error of the rest of the same record through the one phase u. The fit absorbs much
of it, so the residual looks white and nothing estimated from the residual sees it
(``estimation.stats.serial``); but its covariance follows from Q and the fitted motion x̂.
Over the uniform phase, with white noise w ~ N(0, σ_w²) before the quantizer that dithers it
(Fourier series of the sawtooth, s(y) = Σ_k (Q/πk)(−1)^{k+1} sin(2πky/Q)):

    Cov(e_s, e_t) = Σ_k c_k·d_k·cos(2πk(x̂_s − x̂_t)/Q)          (s ≠ t, same record)
    Var(e_t)      = Q²/12 + σ_w²
    c_k = Q²/(2π²k²),  d_k = exp(−(2πkσ_w/Q)²)                     (Σ_k c_k = Q²/12)

records independent of one another (each its own phase); the constant u is absorbed by the
record's fitted position offset. Written as Σ_k c_k·d_k·(cₖcₖᵀ + sₖsₖᵀ) + (Var − Σ_k c_k d_k)·I
with cₖ = cos(2πk x̂/Q), sₖ = sin(2πk x̂/Q), the scores' covariance is

    S_q = Σ_records Σ_{k ≤ K} c_k d_k·(Jᵀcₖ cₖᵀJ + Jᵀsₖ sₖᵀJ) + (Var − Σ_{k≤K} c_k d_k)·JᵀJ

and the estimate's covariance (JᵀJ)⁻¹·S_q·(JᵀJ)⁻¹ (the first-order change of a least-squares
fit under a position error δx is (JᵀJ)⁻¹Jᵀδx; Q is far smaller than any scale on which the
model bends). The K = ``HARMONICS`` first harmonics carry all but 6/(π²K) of the sawtooth's
variance (1 % at K = 64); the rest is counted as white, and so is every harmonic the noise
has damped below 10⁻⁶ (d_k, which falls with k). σ_w² = max(0, σ̂² − Q²/12) is the
part of the residual variance the quantizer does not explain (σ̂² = SSE/(n − p)): noise of
σ_w ≳ Q/2 dithers the quantizer and the error is white again (d_1 < 10⁻⁴).

The step Q is read from the record (``encoder_step``): the smallest non-zero change between
successive positions, when every change is a whole number of it; a record whose positions
are not on such a grid (analogue or already noisy floats) has no step and no such term.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: Harmonics of the sawtooth followed exactly; the remaining 6/(π²·64) ≈ 1 % of Q²/12 is
#: counted as white error.
HARMONICS = 64
#: A harmonic damped below this by the noise that dithers the encoder is left out (its
#: share of Q²/12 is counted as white, where it belongs).
DAMPED = 1e-6
#: Every successive change must be within this fraction of Q of a whole number of steps
#: (positions written as decimals carry float rounding far below it).
ON_GRID_TOLERANCE = 0.01
#: Fewest non-zero changes from which a step is read, and how many of the smallest are
#: searched for the step.
MIN_STEPS, PROBE = 5, 40
#: Most counts the smallest change may span (a record faster than this everywhere is one
#: whose quantization is white: no step is read).
MAX_STEPS_PER_SAMPLE = 1000


def encoder_step(position: np.ndarray) -> float:
    """Q, the position record's quantization step (m or rad), or 0 when the record is not
    on a grid. On the ``PROBE`` smallest non-zero changes |Δx|: the largest Δ_min/d
    (d = 1, 2, … up to ``MAX_STEPS_PER_SAMPLE``) of which each is a whole number within
    ``ON_GRID_TOLERANCE`` (a fast record moves several counts between samples, so its
    smallest change may be a multiple of the step; off-grid changes pass by chance with
    probability about (2·tolerance)^changes). Then Q = Σ n·|Δx| / Σ n² by least squares
    over all changes (n their whole numbers of counts: positions written with few digits
    make Δ_min alone inexact), and every change must be within the tolerance of n·Q."""
    x = np.asarray(position, dtype=float)
    x = x[np.isfinite(x)]
    if x.size < 2:
        return 0.0
    steps = np.abs(np.diff(x))
    moved = steps[steps > 1e-9 * max(float(np.max(np.abs(x))), 1e-300)]
    if moved.size < MIN_STEPS:
        return 0.0
    probe = np.sort(moved)[:PROBE]
    divisors = np.arange(1, MAX_STEPS_PER_SAMPLE + 1, dtype=float)
    counts = np.outer(probe / probe[0], divisors)
    near = np.all(np.abs(counts - np.round(counts)) <= ON_GRID_TOLERANCE, axis=0)
    if not near.any():
        return 0.0
    quantum = float(probe[0] / divisors[near][0])
    for _ in range(2):  # the second pass with the counts of the refined step
        n = np.round(moved / quantum)
        quantum = float(n @ moved / (n @ n))
    n = np.round(moved / quantum)
    return quantum if np.max(np.abs(moved / quantum - n)) <= ON_GRID_TOLERANCE else 0.0


def quantization_scores(
    fitted_positions: np.ndarray,
    jacobian: np.ndarray,
    record_sizes: Sequence[int],
    steps: Sequence[float],
    residual_variance: float,
) -> np.ndarray | None:
    """S_q, the covariance of the scores Jᵀe under the quantization of each record's fitted
    motion ``fitted_positions`` (x̂, the records concatenated) to its step (module doc); a
    record with step 0 contributes white error of ``residual_variance``. None when no record
    is quantized."""
    if not any(q > 0 for q in steps):
        return None
    x = np.asarray(fitted_positions, dtype=float)
    jac = np.asarray(jacobian, dtype=float)
    if sum(record_sizes) != x.size or len(steps) != len(record_sizes):
        raise ValueError(
            f"record_sizes: {len(record_sizes)} records of {sum(record_sizes)} samples, "
            f"allowed: {len(steps)} steps and {x.size} samples"
        )
    harmonic = np.arange(1, HARMONICS + 1, dtype=float)
    meat = np.zeros((jac.shape[1], jac.shape[1]))
    start = 0
    for size, quantum in zip(record_sizes, steps, strict=True):
        block = slice(start, start + size)
        start += size
        j = jac[block]
        if quantum <= 0:
            meat += residual_variance * (j.T @ j)
            continue
        noise = max(residual_variance - quantum**2 / 12.0, 0.0)
        damping = np.exp(-((2 * np.pi * harmonic * np.sqrt(noise) / quantum) ** 2))
        kept = int(np.count_nonzero(damping > DAMPED))  # d_k falls with k
        weight = quantum**2 / (2 * np.pi**2 * harmonic[:kept] ** 2) * damping[:kept]
        # e^{2πik·x̂/Q} for k = 1…K as powers of the first harmonic, of x̂'s position within
        # its count (whole counts drop out of an integer harmonic; the arguments stay small)
        first = np.exp(2j * np.pi * np.mod((x[block] - x[block][0]) / quantum, 1.0))
        waves = np.cumprod(np.broadcast_to(first[:, None], (size, kept)), axis=1)
        waves *= np.sqrt(weight)
        cosine, sine = j.T @ waves.real, j.T @ waves.imag  # Jᵀcₖ, Jᵀsₖ, weighted (real BLAS)
        meat += cosine @ cosine.T + sine @ sine.T
        meat += (quantum**2 / 12.0 + noise - weight.sum()) * (j.T @ j)
    return meat
