"""The start-at-rest check (``estimation.axis.release.speed_at_release``) on tows from the
term-library generator (solve_ivp, not our simulator): a record cut after its release is
called moving; correlated noise on a record that starts at rest is not."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from estimation import estimate
from estimation.axis.release import speed_at_release
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


def _sparse(run, rng, baseline):
    """``run`` kept at 24 irregular instants: ``baseline`` samples up to its release, then 23
    drawn at random from the rest of its 20 s (about one per 0.8 s)."""
    idx = np.sort(rng.choice(np.arange(11, run.t.size), 23, replace=False))
    idx = np.concatenate([np.arange(11 - baseline, 11), idx])
    return replace(run, t=run.t[idx], position=run.position[idx])


@pytest.mark.parametrize("scale", ["10kg", "143kg", "1000kg"])
@pytest.mark.parametrize("baseline", [1, 2], ids=["from-the-release", "one-held-sample"])
def test_a_sparse_record_that_starts_at_rest_is_not_called_moving(scale, baseline):
    """24 irregular points per tow, from rest: seven samples spanned the whole acceleration
    and their parabola's slope was read as a speed at the release (11 of 12 runs); the
    parabola now reads only samples well below the top speed."""
    rng = np.random.default_rng(7)
    runs = [_sparse(r, rng, baseline) for seed in range(4) for r in tow_set(scale, seed)]
    assert all(r.t.size <= 30 for r in runs)
    assert [speed_at_release(r) for r in runs] == [None] * len(runs)


def test_a_drive_ahead_of_its_log_is_a_lag_not_a_moving_start():
    """The 143 kg tows whose pull began 0.15 s before the logged release (the log lags the
    drive; the held samples before it are in the record): a lag, so the inertia keeps its σ
    and no run is called "already moving" (three of four were, at 0.03–0.1 m/s)."""
    r = estimate(tow_set("143kg", 0, delay=-0.15), n_bootstrap=0)
    assert not any("already moving" in w for w in r.warnings), r.warnings
    assert np.isfinite(r.coefficients["inertia"].std)


def test_a_dense_record_cut_while_still_accelerating_is_called_moving():
    """The 143 kg tows recorded from 0.2 s after their release (still accelerating, speed
    ≈ F/M·0.2 s): too few samples stay below 30 % of the top speed for the parabola, and the
    three first samples' parabola gives the speed at the release within 15 %."""
    for run in tow_set("143kg", 0):
        keep = run.t >= 1.2
        cut = replace(run, t=run.t[keep], position=run.position[keep], t_release=1.2)
        speed = speed_at_release(cut)
        assert speed is not None and speed == pytest.approx(run.drive / 143.26 * 0.2, rel=0.15)


def test_ten_cate_e1_begins_after_its_release_and_is_called_moving():
    """The published settling sphere E1 (24 points, first 0.084 s after the release at
    t = 0) is at 0.031 m/s of its 0.034 m/s terminal speed there: a record that begins after
    its release has no start to bound, so its first samples are read as they are."""
    import pandas as pd

    from estimation import RunData
    from tests.support.shared_data import shared_file

    d = pd.read_csv(shared_file("real", "tencate-sphere-settling", "tencate_E1_tow.csv"))
    run = RunData("E1", "surge", d.t.to_numpy(), d.position.to_numpy(), drive=0.0026004)
    assert speed_at_release(run) == pytest.approx(0.031, rel=0.1)


def test_sparse_tows_from_rest_keep_their_inertia():
    """The estimate of four 24-point tows from rest at 143 kg: no run is called moving, and
    the inertia keeps its σ and lands on its truth (it was left without σ: "already moving
    at its release")."""
    rng = np.random.default_rng(7)
    r = estimate([_sparse(run, rng, 1) for run in tow_set("143kg", 0)], n_bootstrap=0)
    assert not any("already moving" in w for w in r.warnings), r.warnings
    inertia = r.coefficients["inertia"]
    assert np.isfinite(inertia.std) and inertia.value == pytest.approx(143.26, rel=0.01)


@pytest.mark.parametrize("scale", ["10kg", "143kg", "1000kg"])
def test_a_sparse_record_of_a_lagged_drive_is_not_called_moving(scale):
    """24 irregular points of tows whose pull began 0.1 or 0.3 s before the logged release,
    with two held samples (t = 0 and 0.5 s) before the motion: the record shows the rest,
    so a speed at the logged release is a lag (rule 1), however sparse the rest of it. Two
    seeds per lag (each check is a few ms; 2 lags × 2 seeds × 4 drives = 16 runs a scale)."""
    runs = []
    for lag in (0.1, 0.3):
        for seed in (0, 1):
            rng = np.random.default_rng(seed)
            for run in tow_set(scale, seed, delay=-lag):
                idx = np.r_[0, 5, np.sort(rng.choice(np.arange(11, run.t.size), 22, False))]
                runs.append(replace(run, t=run.t[idx], position=run.position[idx]))
    assert all(r.t.size <= 30 for r in runs)
    assert [speed_at_release(r) for r in runs] == [None] * len(runs)
