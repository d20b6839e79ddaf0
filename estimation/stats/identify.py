"""Standard errors that never hide a direction the data cannot determine, and never assume a
residual whiter than it is.

Three covariances of the estimate, all on the column-scaled Jacobian J·D⁻¹ (D = column
norms) through its singular values s_k:

    white:  cov_w = σ̂²·(JᵀJ)⁻¹,  σ̂² = SSE/(n − p)
    serial: cov_s = n/(n − p)·(JᵀJ)⁻¹·S·(JᵀJ)⁻¹   (S: the scores' long-run covariance within
            each record, ``estimation.stats.serial``)
    quantization: cov_q = (JᵀJ)⁻¹·S_q·(JᵀJ)⁻¹   (S_q: the scores' covariance under the
            encoder's quantization of the fitted motion, ``estimation.stats.quantization``;
            only for records on an encoder grid)

Each parameter's σ is the largest of them: cov_s accounts for residuals correlated in time
(structure no term explains), but its S is an estimate from the same residuals, biased low
in finite samples (the Bartlett weights shrink the autocovariances and the fit has already
absorbed the residual along J); where it comes out below cov_w the data do not show that the
correlation really makes θ̂ more precise than white noise would, so the σ the data support
is the white one. cov_q models the same noise of the samples with the correlation one
unknown phase per record gives a quantized smooth motion, which the fit absorbs and the
residual does not show. They estimate one error: the largest, not their sum. The
correlation matrix is cov_s's (the σ then rescale it).

A direction with s_k/s_max < ``RANK_TOL`` is not determined by the data: a finite-difference
Jacobian is only good to about 1e-6 of its largest column, so a smaller singular value cannot
be told from that error. A pseudo-inverse would drop such a direction and give every
parameter along it a σ that is far too small; here each parameter with more than
``NULL_LOADING`` of its unit vector in those directions is reported as **not identified**
(σ = NaN, written as null), and the σ of the others (orthogonal to them) is exact.
The same holds for a combination Σ g_i·θ_i of the parameters (a terminal speed, a drag at
a speed): its σ² = gᵀ·C·g (C = D_σ·R·D_σ, the σ above and cov_s's correlation, the
pseudo-inverse's on the determined directions) is given when its scaled gradient g·D⁻¹ has
no more than ``NULL_LOADING`` of its length in those directions (``Combinations``), even
when every θ_i it combines is not identified alone (a settling sphere's K_L and K_Q trade
along the one steady balance its record shows; the speed it settles at is known).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.stats.fit_statistics import Combinations
from estimation.stats.quantization import quantization_scores
from estimation.stats.serial import long_run_scores

RANK_TOL = 1e-6
NULL_LOADING = 0.01


@dataclass(frozen=True)
class Identified:
    """σ (NaN where not identified), correlation, and which of the first parameters the data
    do not determine; ``std_white`` is the white-residual σ the reported one never goes
    below."""

    std: np.ndarray
    correlation: np.ndarray
    not_identified: np.ndarray  # bool per global parameter
    sse: float
    n_samples: int
    n_params: int
    std_white: np.ndarray
    #: the σ of the records' quantization alone (``estimation.stats.quantization``); None
    #: when no record is on an encoder grid
    std_quantization: np.ndarray | None = None
    #: σ of combinations of the parameters (module doc)
    combinations: Combinations | None = None

    def fit_fields(self) -> dict[str, Any]:
        """The fields every fit reports from these statistics (``FitStatistics``'s σ,
        correlation, SSE, n and p), for its constructor."""
        return {
            "std": self.std,
            "std_white": self.std_white,
            "std_quantization": self.std_quantization,
            "combinations": self.combinations,
            "correlation": self.correlation,
            "sse": self.sse,
            "n_samples": self.n_samples,
            "n_params": self.n_params,
        }


def honest_statistics(
    residuals: np.ndarray,
    jacobian: np.ndarray,
    n_global: int,
    record_sizes: Sequence[int],
    fitted_positions: np.ndarray | None = None,
    steps: Sequence[float] = (),
) -> Identified:
    """σ and correlation of the first ``n_global`` parameters (module doc); ``residuals``
    and ``jacobian`` are the records' samples concatenated, ``record_sizes`` their counts;
    ``fitted_positions`` (the model at the samples) and each record's encoder ``steps``
    (0: not quantized) add the quantization σ."""
    residuals = np.asarray(residuals, dtype=float)
    n, p = residuals.size, jacobian.shape[1]
    sse = float(residuals @ residuals)
    jac = np.nan_to_num(np.asarray(jacobian, dtype=float))
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    scaled = jac / norms
    _, s, vt = np.linalg.svd(scaled, full_matrices=False)
    keep = s > RANK_TOL * (s[0] if s.size else 0.0)
    null = vt[~keep]
    loading = np.sqrt(np.sum(null**2, axis=0)) if null.size else np.zeros(p)
    lost = loading > NULL_LOADING
    inv = (vt[keep].T / s[keep] ** 2) @ vt[keep]
    unscale = np.outer(norms, norms)
    cov_white = sse / max(n - p, 1) * inv / unscale
    meat = long_run_scores(residuals, scaled, record_sizes)
    cov_serial = n / max(n - p, 1) * (inv @ meat @ inv) / unscale
    g = n_global
    white = np.sqrt(np.maximum(np.diag(cov_white)[:g], 0.0))
    serial = np.sqrt(np.maximum(np.diag(cov_serial)[:g], 0.0))
    larger, quantization = np.maximum(white, serial), None
    if fitted_positions is not None and len(steps):
        variance = sse / max(n - p, 1)
        meat_q = quantization_scores(fitted_positions, scaled, record_sizes, steps, variance)
        if meat_q is not None:
            cov_q = (inv @ meat_q @ inv) / unscale
            quantization = np.sqrt(np.maximum(np.diag(cov_q)[:g], 0.0))
            larger = np.maximum(larger, quantization)
            quantization = np.where(lost[:g], np.nan, quantization)
    std = np.where(lost[:g], np.nan, larger)
    std_white = np.where(lost[:g], np.nan, white)
    denom = np.outer(serial, serial)
    ok = np.isfinite(np.outer(std, std)) & (denom > 0)
    corr = np.divide(cov_serial[:g, :g], np.where(ok, denom, 1.0), out=np.eye(g), where=ok)
    corr = np.where(ok | np.eye(g, dtype=bool), corr, np.nan)
    every = np.divide(cov_serial[:g, :g], denom, out=np.eye(g), where=denom > 0)
    combinations = Combinations(
        np.outer(larger, larger) * every,
        null[:, :g],
        norms[:g].copy(),
        NULL_LOADING,
        cov_white[:g, :g].copy(),
    )
    return Identified(std, corr, lost[:g].copy(), sse, n, p, std_white, quantization, combinations)
