"""Standard errors that never hide a direction the data cannot determine.

cov = σ̂²·(JᵀJ)⁻¹ with σ̂² = SSE/(n − p), computed on the column-scaled Jacobian J·D⁻¹
(D = column norms) by its singular values s_k. A direction with s_k/s_max < ``RANK_TOL``
is not determined by the data: a finite-difference Jacobian is only good to about 1e-6 of
its largest column, so a smaller singular value cannot be told from that error. A
pseudo-inverse would drop such a direction and give every parameter along it a σ that
is far too small; here each parameter with more than ``NULL_LOADING`` of its unit vector in
those directions is reported as **not identified** (σ = NaN, written as null), and the σ of
the others (orthogonal to them) is exact.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RANK_TOL = 1e-6
NULL_LOADING = 0.01


@dataclass(frozen=True)
class Identified:
    """σ (NaN where not identified), correlation, and which of the first parameters the data
    do not determine."""

    std: np.ndarray
    correlation: np.ndarray
    not_identified: np.ndarray  # bool per global parameter
    sse: float
    n_samples: int
    n_params: int


def honest_statistics(residuals: np.ndarray, jacobian: np.ndarray, n_global: int) -> Identified:
    """σ and correlation of the first ``n_global`` parameters (module doc)."""
    n, p = residuals.size, jacobian.shape[1]
    sse = float(residuals @ residuals)
    jac = np.nan_to_num(np.asarray(jacobian, dtype=float))
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    _, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
    keep = s > RANK_TOL * (s[0] if s.size else 0.0)
    null = vt[~keep]
    loading = np.sqrt(np.sum(null**2, axis=0)) if null.size else np.zeros(p)
    lost = loading > NULL_LOADING
    inv = (vt[keep].T / s[keep] ** 2) @ vt[keep]
    cov = sse / max(n - p, 1) * inv / np.outer(norms, norms)
    g = n_global
    std = np.sqrt(np.maximum(np.diag(cov)[:g], 0.0))
    std = np.where(lost[:g], np.nan, std)
    denom = np.outer(std, std)
    ok = np.isfinite(denom) & (denom > 0)
    corr = np.divide(cov[:g, :g], np.where(ok, denom, 1.0), out=np.eye(g), where=ok)
    corr = np.where(ok | np.eye(g, dtype=bool), corr, np.nan)
    return Identified(std, corr, lost[:g].copy(), sse, n, p)
