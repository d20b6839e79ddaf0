"""The record-level bootstrap is every kind's (issue 31, item 2): free decays and pendulum
swings with three records or more carry the one a tow set has (``motion.record_bootstrap``);
two records, or a tow pair, have none: their few resamples give a spread of ~0.

Records from scipy's solve_ivp (``tests.estimation.term_cases.decay``: a 143 kg heave
decay, 20 µm noise), not our integrator.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimation.motion.decay_estimate import estimate_records
from estimation.motion.output_error_fit import fit_motion, fitted_values, parameters_of
from estimation.motion.records import Record, Setup
from tests.estimation.term_cases import decay


def _records(n: int) -> tuple[list[Record], dict]:
    records, truth = [], {}
    for seed in range(1, n + 1):
        t, x, truth = decay("143kg", seed)
        records.append(Record(f"r{seed}", t, x))
    return records, truth


def test_a_decay_of_three_records_carries_the_bootstrap_of_its_coefficients():
    """Three records of one body: each draw refits a resample; the spread of the added mass
    over the draws is the records' scatter, of the order of the fit's own σ (they differ
    only by their white noise), and its 95 % interval holds the estimate."""
    records, truth = _records(3)
    result = estimate_records(
        records, "heave", known_inertia=truth["known"], stiffness=truth["k"], n_bootstrap=12
    )
    boot = result.bootstrap
    assert boot is not None and boot.requested == 12 and boot.used == 12
    added = result.coefficients["inertia"]
    assert boot.low["inertia"] <= added.value <= boot.high["inertia"]
    assert 0.1 * added.std < boot.std["inertia"] < 10 * added.std
    doc = result.to_json()["bootstrap"]
    assert doc["used"] == 12 and doc["std"]["inertia"] == boot.std["inertia"]


def test_one_record_has_no_bootstrap_and_zero_draws_are_allowed_but_not_fewer():
    records, truth = _records(2)
    one = estimate_records(records[:1], "heave", known_inertia=truth["known"], stiffness=truth["k"])
    assert one.bootstrap is None and one.to_json()["bootstrap"] is None
    two = estimate_records(records, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    assert two.bootstrap is None  # three resamples, two of them one record twice
    none = estimate_records(
        records, "heave", known_inertia=truth["known"], stiffness=truth["k"], n_bootstrap=0
    )
    assert none.bootstrap is None
    assert np.isfinite(none.coefficients["inertia"].value)
    with pytest.raises(ValueError, match="n_bootstrap: got -1, allowed: >= 0"):
        estimate_records(records, "heave", stiffness=truth["k"], n_bootstrap=-1)


def test_a_tow_pair_resamples_only_to_itself_and_claims_no_spread():
    """Two tows at different loads: the only usable resample is the pair itself (one load
    twice cannot separate K_L from K_Q), so every draw is the same fit; a σ of ~0 from it
    would claim a precision the runs do not have. None is given, and the budget has no
    bootstrap row."""
    from estimation import estimate
    from tests.estimation.synth import tow_set

    runs = tow_set(seed=3)[:2]
    doc = estimate(runs, n_bootstrap=20).to_json()
    assert doc["bootstrap"]["used"] == 0
    assert all(v is None for v in doc["bootstrap"]["std"].values())


def test_a_draw_keeps_the_coefficients_the_full_fit_finds_bit_for_bit():
    """A draw computes only its coefficients (``fitted_values``): the same numbers
    ``fit_motion`` gives from the same resample and start, not an approximation of them."""
    records, truth = _records(3)
    setup = Setup("heave", truth["known"], known_terms={"restoring_spring": truth["k"]},
                  terms=("linear_damping",))  # fmt: skip
    fit = fit_motion(records, setup, ("quadratic_damping",))
    pick = [2, 0, 2]
    sample = [records[i] for i in pick]
    full = fit_motion(sample, setup, fit.effects, start=parameters_of(fit, pick), max_nfev=50)
    alone = fitted_values(sample, setup, fit.effects, parameters_of(fit, pick), 50)
    assert alone.tobytes() == full.values.tobytes()
    assert not np.array_equal(alone, fit.values)  # the resample moved them
