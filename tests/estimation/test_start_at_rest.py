"""The start-at-rest check (``estimation.axis.release.speed_at_release``) on tows from the
term-library generator (solve_ivp, not our simulator): a record cut after its release is
called moving; correlated noise on a record that starts at rest is not."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from estimation import estimate
from tests.estimation.term_cases import tow_set


def _ar1(runs, rho, sigma, seed):
    """Each run's position plus AR(1) noise of marginal σ ``sigma`` (m) and lag-1 ρ."""
    rng = np.random.default_rng(seed)
    out = []
    for r in runs:
        e = np.empty(r.t.size)
        e[0] = sigma * rng.standard_normal()
        for i in range(1, e.size):
            e[i] = rho * e[i - 1] + sigma * np.sqrt(1 - rho**2) * rng.standard_normal()
        out.append(replace(r, position=r.position + e))
    return out


@pytest.mark.parametrize("seed", [2, 5])
def test_correlated_noise_on_a_tow_from_rest_is_not_a_moving_start(seed):
    """ρ 0.9, 3 mm at 1000 kg: seven samples of such noise look like a drift; the check
    widens its σ by the AR(1) inflation of the run's residual, so the inertia keeps its σ
    and its 2σ covers the truth (these seeds were called "already moving" before)."""
    runs = _ar1(tow_set("1000kg", seed), 0.9, 3e-3, 1000 + seed)
    r = estimate(runs, n_bootstrap=0)
    assert not any("already moving" in w for w in r.warnings), r.warnings
    inertia = r.coefficients["inertia"]
    assert np.isfinite(inertia.std) and abs(inertia.value - 1000.0) <= 2 * inertia.std


def test_a_tow_recorded_from_after_its_release_is_called_moving():
    """The 143 kg tows with their first 1.5 s after the release cut off and the release put
    at the first sample kept: the body is at speed there, so the inertia has no σ."""
    cut = []
    for run in tow_set("143kg", 0):
        keep = run.t >= 2.5
        cut.append(replace(run, t=run.t[keep], position=run.position[keep], t_release=2.5))
    r = estimate(cut, n_bootstrap=0)
    assert any("already moving at its release" in w for w in r.warnings), r.warnings
    assert not np.isfinite(r.coefficients["inertia"].std)
