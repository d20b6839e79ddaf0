"""Seed 000's three approaches on data regenerated from the paper's published curve fits."""

from dataclasses import replace

import numpy as np
import pytest

from estimation import estimate
from tests.estimation.synth import paper_curve_runs, tow_set

TABLE1_INERTIA = {"surge": (133.2060, 143.2591), "yaw": (7.0796, 7.9708)}


@pytest.mark.parametrize("axis", ["surge", "yaw"])
@pytest.mark.parametrize("method", ["ls-curvefit", "ls-steady"])
def test_approaches_2_and_3_land_near_table_1(axis, method):
    low, high = TABLE1_INERTIA[axis]
    doc = estimate(paper_curve_runs(axis), method=method).to_json()
    inertia = doc["coefficients"]["inertia"]
    print(f"{axis} {method}: inertia {inertia['value']:.4g} ± {inertia['std']:.2g}")
    assert 0.95 * low <= inertia["value"] <= 1.03 * high
    assert doc["method"] == method and doc["effects"] == []
    assert all(
        np.isfinite(doc["coefficients"][k]["std"]) and doc["coefficients"][k]["std"] > 0
        for k in doc["coefficients"]
    )


@pytest.mark.parametrize("axis", ["surge", "yaw"])
def test_raw_differences_collapse_on_a_coarse_encoder(axis):
    low, _ = TABLE1_INERTIA[axis]
    fine = estimate(paper_curve_runs(axis, quantum=1e-4), method="ls-raw").to_json()
    coarse = estimate(paper_curve_runs(axis, quantum=5e-3), method="ls-raw").to_json()
    steady = estimate(paper_curve_runs(axis, quantum=5e-3), method="ls-steady").to_json()
    assert fine["coefficients"]["inertia"]["value"] > 0.9 * low
    # differentiating twice amplifies the encoder step: the inertia collapses (paper: 8 kg)
    assert coarse["coefficients"]["inertia"]["value"] < 0.2 * low
    assert steady["coefficients"]["inertia"]["value"] > 0.95 * low
    assert coarse["rmse_after"] > 2 * steady["rmse_after"]


@pytest.mark.parametrize("method", ["ls-curvefit", "ls-steady"])
def test_the_curve_methods_need_two_drive_levels(method):
    """One drive level's first-order curves are fitted exactly by (M, K_L, K_Q) with
    K_Q = 0 (ls-curvefit once returned 0 ± 1e-10 for it, every σ ~1e-11): both curve methods
    refuse one level, naming the runs' drive, what they need and what takes one run."""
    runs = paper_curve_runs("surge")
    one_level = [runs[0], replace(runs[0], run_id="again")]
    for refused in (runs[:1], one_level):
        with pytest.raises(
            ValueError,
            match=rf"runs: drive: got one drive level \(\S+ N\), allowed: two or more "
            rf"different forces/torques for {method} .*output-error and ls-raw take one run",
        ):
            estimate(refused, method=method)
    assert estimate(runs[:2], method=method, n_bootstrap=0).method == method


def test_a_seed_result_that_misfits_its_runs_says_so_whatever_its_sigma():
    """ls-curvefit on four clean tows: K_L 26.7 ± 8.2 against the truth 20.16, a σ wide
    enough that the comparison with output error (``method_bias``) finds nothing, while the
    positions its coefficients predict leave a force residual ~25× the noise floor (output
    error: ~1×). The misfit rule every result's residual is judged by says so, with output
    error's figure beside it, and names the slow drift a drag law leaves as a trend, not as a
    sinusoid whose period is the longest one tried."""
    runs = tow_set(axis="surge")
    seed = estimate(runs, method="ls-curvefit", n_bootstrap=0)
    reference = estimate(runs, n_bootstrap=0, search_effects=False)
    assert seed.possibly_biased is True and reference.possibly_biased is False
    assert not any(" is biased on these runs" in w for w in seed.warnings)  # σ hides it
    (misfit,) = [w for w in seed.warnings if "do not reproduce the runs" in w]
    floor = seed.section.unexplained.ratio
    assert floor > 10
    assert f"{floor:.1f}× the noise floor" in misfit
    beside = reference.section.unexplained.ratio
    assert f"output-error fit of the same runs leaves {beside:.1f}×" in misfit
    assert "sign the output-error result" in misfit
    assert "periodic in time" not in misfit
    doc = seed.to_json()
    assert doc["coefficients_possibly_biased"] is True
    assert doc["unexplained"]["structured"] is True


def test_a_seed_method_that_agrees_with_output_error_is_not_called_a_misfit():
    """On a coarse (5 mm) encoder ls-steady's first-order curves fit the record as well as the
    quadratic model does (force residual within 3× its floor): no misfit warning."""
    runs = paper_curve_runs("surge", quantum=5e-3)
    seed = estimate(runs, method="ls-steady", n_bootstrap=0)
    assert seed.possibly_biased is False
    assert not any("do not reproduce the runs" in w for w in seed.warnings)
