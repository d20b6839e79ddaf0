"""What every fitted model reports the same way: BIC, RMSE, values by name."""

from __future__ import annotations

import numpy as np


class FitStatistics:
    """Mixin for fit results with ``names``, ``values``, ``std``, ``residuals`` (per run),
    ``sse``, ``n_samples`` and ``n_params``."""

    names: tuple[str, ...]
    values: np.ndarray
    std: np.ndarray
    residuals: tuple[np.ndarray, ...]
    sse: float
    n_samples: int
    n_params: int

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
