"""Numerical care in the tow/spin fit: the leave-one-run-out verdict on a tie, the RK4 step
on a heavily damped record, σ machinery skipped where a refit's σ is discarded."""

from __future__ import annotations

import numpy as np

from estimation.axis.model import prepare
from estimation.axis.output_error import (
    LORO_RESOLUTION,
    fit_output_error,
    leave_one_run_out_rmse,
    loro_dropped,
)
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set


def test_a_candidate_at_zero_ties_with_the_model_without_it_and_is_no_drop():
    """A force that aids forward tows wants a negative dry friction: the friction sits at its
    bound 0, the fit is the base model, and the two leave-one-run-out RMSEs differ only by
    where the refits stopped. That difference is no drop, whichever way it falls."""
    runs = [prepare(r) for r in tow_set(Physics(*SURGE_TRUTH, bias=0.5), seed=3)]
    base = fit_output_error(runs)
    pinned = fit_output_error(runs, ("coulomb_friction",), start=np.r_[base.values, 0.0])
    assert "coulomb_friction" in pinned.at_bound
    cv_base = leave_one_run_out_rmse(runs, base)
    cv_pinned = leave_one_run_out_rmse(runs, pinned)
    assert cv_base is not None and cv_pinned is not None
    assert abs(cv_pinned / cv_base - 1) < LORO_RESOLUTION  # a tie
    assert not loro_dropped(cv_pinned, cv_base) and not loro_dropped(cv_base, cv_pinned)
    # a bare "<" on round-off called one of them a drop; a resolved drop is still one
    assert not loro_dropped(cv_base * (1 - 1e-14), cv_base)
    assert loro_dropped(cv_base * (1 - 10 * LORO_RESOLUTION), cv_base)


def test_bootstrap_and_leave_one_run_out_refits_skip_the_quantization_sigma(monkeypatch):
    """Their σ is discarded (only values and predictions are kept): the quantization σ is
    not computed for them, and their values are those of a refit that computes it."""
    import estimation.stats.identify as identify
    from estimation.axis.estimate import _bootstrap

    runs = [prepare(r) for r in tow_set(seed=4)]
    fit = fit_output_error(runs)
    assert fit.std_quantization is not None  # the reported fit carries it
    calls: list[int] = []
    real = identify.quantization_scores

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(identify, "quantization_scores", counted)
    boot = _bootstrap(runs, fit, 6, 0)
    assert boot.used >= 3
    assert leave_one_run_out_rmse(runs, fit) is not None
    assert calls == []
    train = runs[1:]
    with_sigma = fit_output_error(train, start=fit.values)
    without = fit_output_error(train, start=fit.values, quantization_sigma=False)
    assert calls == [1] and without.std_quantization is None
    np.testing.assert_array_equal(without.values, with_sigma.values)
