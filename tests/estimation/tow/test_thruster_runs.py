"""Thruster-driven runs: per-sample thrust as the input, integrated model, both directions."""

import numpy as np
import pytest

from estimation import estimate
from tests.estimation.synth import SURGE_TRUTH, Physics, thruster_run

LEVELS = ((20.0, -20.0, 0.0), (45.0, -45.0, 0.0), (70.0, 0.0))


def _runs(phys):
    return [thruster_run(phys, lv, run_id=f"thr-{i}") for i, lv in enumerate(LEVELS)]


def test_clean_thruster_runs_recover_coefficients_without_effects():
    doc = estimate(_runs(Physics(*SURGE_TRUTH)), n_bootstrap=0).to_json()
    values = np.array(
        [
            doc["coefficients"][k]["value"]
            for k in ("inertia", "linear_damping", "quadratic_damping")
        ]
    )
    assert np.all(np.abs(values / np.array(SURGE_TRUTH) - 1) < 0.01)
    assert doc["effects"] == []


@pytest.mark.slow
def test_reversing_thrust_names_coulomb_friction_unambiguously():
    doc = estimate(_runs(Physics(*SURGE_TRUTH, coulomb=4.0)), n_bootstrap=0).to_json()
    names = [e["name"] for e in doc["effects"]]
    assert names[0] == "coulomb_friction"
    assert doc["effects"][0]["value"] == pytest.approx(4.0, rel=0.1)
    assert doc["ambiguous"] == []
    assert doc["rmse_after"] < 0.2 * doc["rmse_before"]


def test_seed_methods_on_a_reversing_thrust_refuse_or_cover_the_truth():
    """A seed method on thruster runs whose thrust reverses (20 → −20 → 0 N, …): ls-raw
    regresses each sample on its own drive and recovers the coefficients within 2σ; the
    curve-fit methods model a first-order rise under one drive held one way, which these
    runs do not have, so they refuse them naming the run and the drive's range instead of
    fitting a curve the record does not follow (``seed_methods.one_way_drives``)."""
    runs = _runs(Physics(*SURGE_TRUTH))
    doc = estimate(runs, method="ls-raw", n_bootstrap=0).to_json()
    for name, truth in zip(
        ("inertia", "linear_damping", "quadratic_damping"), SURGE_TRUTH, strict=True
    ):
        c = doc["coefficients"][name]
        assert abs(c["value"] - truth) < 2 * c["std"], (name, c, truth)
    for method in ("ls-curvefit", "ls-steady"):
        with pytest.raises(
            ValueError,
            match=r"runs: thr-0: drive: got a drive that reverses "
            r"after the release \(-20 to 20 N\), allowed: one "
            rf"direction per run for {method}",
        ):
            estimate(runs, method=method, n_bootstrap=0)
