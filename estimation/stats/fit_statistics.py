"""What every fitted model reports the same way: σ and correlation from the Jacobian,
BIC, RMSE, values by name."""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, replace
from typing import Self

import numpy as np


@dataclass(frozen=True)
class Combinations:
    """What σ of a combination Σ g_i·θ_i of a fit's coefficients needs (``stats.identify``):
    the coefficients' covariance C (the pseudo-inverse's where the data leave a direction
    undetermined; NaN rows for coefficients whose σ was withdrawn), the undetermined
    directions (rows, in the column-scaled coordinates θ·D), the column scales D, the
    share of its length a combination may have along those directions (``null_loading``:
    the rule one coefficient's σ follows, ``stats.identify.NULL_LOADING``), and the white
    covariance σ̂²·(JᵀJ)⁺ of the coefficients alone (the nuisances profiled out), from which
    a planner adds a planned record's information (``design.decay_information``)."""

    covariance: np.ndarray
    null: np.ndarray
    scale: np.ndarray
    null_loading: float
    white: np.ndarray

    def std(self, gradient: np.ndarray) -> float | None:
        """σ = √(gᵀ·C·g), or None when the combination is not determined: its scaled gradient
        g/D loads the undetermined directions by more than ``null_loading`` of its length,
        or it takes a coefficient whose σ was withdrawn."""
        g = np.asarray(gradient, dtype=float)
        used = np.flatnonzero(g)
        if used.size == 0:
            return 0.0
        scaled = g / self.scale
        if self.null.size and np.linalg.norm(self.null @ scaled) > (
            self.null_loading * np.linalg.norm(scaled)
        ):
            return None
        c = self.covariance[np.ix_(used, used)]
        if not np.all(np.isfinite(c)):
            return None
        return float(np.sqrt(max(g[used] @ c @ g[used], 0.0)))

    def without(self, lost: np.ndarray) -> Combinations:
        """These with the coefficients ``lost`` (bool per coefficient) withdrawn."""
        gone = lost[:, None] | lost[None, :]
        return replace(self, covariance=np.where(gone, np.nan, self.covariance))


@dataclass(frozen=True, kw_only=True)
class FitStatistics:
    """A converged fit of named coefficients and effects: values with σ and correlation,
    residuals per run, and the evidence derived from them (subclasses add their nuisance
    parameters and model states)."""

    effects: tuple[str, ...]
    names: tuple[str, ...]  # base coefficients, then effects
    values: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    residuals: tuple[np.ndarray, ...]  # measured − model, per run (m or rad)
    sse: float
    n_samples: int
    n_params: int
    at_bound: tuple[str, ...] = ()  # names whose value sits on a bound
    #: σ̂²(JᵀJ)⁻¹ alone (white residual): the noise of the samples, which ``std`` never goes
    #: below; None when the σ did not come from this fit's Jacobian
    std_white: np.ndarray | None = None
    #: the σ the records' encoder quantization alone gives (``estimation.stats.quantization``),
    #: which ``std`` never goes below; None when no record is quantized or the σ did not
    #: come from this fit's Jacobian
    std_quantization: np.ndarray | None = None
    #: σ of combinations of the coefficients (a terminal speed); None when the σ did not
    #: come from this fit's Jacobian
    combinations: Combinations | None = None

    def combination_std(self, gradient: np.ndarray) -> float | None:
        """σ of Σ g_i·θ_i over ``names`` (``Combinations.std``); None when not determined."""
        return None if self.combinations is None else self.combinations.std(gradient)

    @property
    def bic(self) -> float:
        """Bayesian information criterion n·ln(SSE/n) + p·ln(n)."""
        n = self.n_samples
        return n * np.log(max(self.sse, 1e-300) / n) + self.n_params * np.log(n)

    @property
    def rmse(self) -> float:
        """RMSE over all runs, in the measured quantity's unit (m or rad)."""
        return float(np.sqrt(self.sse / self.n_samples))

    def rmse_per_run(self) -> list[float]:
        """RMSE of each run (m or rad)."""
        return [float(np.sqrt(np.mean(r**2))) for r in self.residuals]

    def value(self, name: str) -> float:
        """Fitted value of the named coefficient or effect (0 when absent)."""
        return float(self.values[self.names.index(name)]) if name in self.names else 0.0

    def sigma(self, name: str) -> float:
        """Standard error of a fitted value (0 when absent)."""
        return float(self.std[self.names.index(name)]) if name in self.names else 0.0

    def without_sigma(self, names: Collection[str]) -> Self:
        """This fit with ``names`` not identified: their σ (every form) and correlations
        unknown (NaN), for what the data cannot determine although the Jacobian gives a
        number (a record that starts moving, a fit held by the simulator's limit)."""
        lost = np.isin(np.array(self.names), list(names))
        if not lost.any():
            return self
        gone = lost[:, None] | lost[None, :]
        correlation = np.where(gone & ~np.eye(lost.size, dtype=bool), np.nan, self.correlation)
        return replace(
            self,
            std=np.where(lost, np.nan, self.std),
            std_white=None if self.std_white is None else np.where(lost, np.nan, self.std_white),
            std_quantization=(
                None
                if self.std_quantization is None
                else np.where(lost, np.nan, self.std_quantization)
            ),
            correlation=correlation,
            combinations=None if self.combinations is None else self.combinations.without(lost),
        )
