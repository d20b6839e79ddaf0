"""The effect search on vehicles far from BENBAM: 10 kg and 1000 kg, data from the test-side
RK4 integrator (tests/estimation/synth.py), never from the simulated rig's plant.

Classes (issue: estimation that stays honest): clean data → no effect; single effects and
pairs that a greedy step misses → named with their values; a force outside the library →
flagged with its correlate and not absorbed.
"""

import numpy as np
import pytest

from estimation import estimate
from estimation.data.run_arrays import RunData
from tests.estimation.synth import Physics, tow_set

#: (inertia kg, K_L N·s/m, K_Q N·s²/m², forward drives N) per scale.
SCALES = {
    "10kg": (10.0, 2.0, 15.0, (0.6, 1.5, 3.0, 6.0)),
    "1000kg": (1000.0, 150.0, 1500.0, (60.0, 150.0, 300.0, 600.0)),
}


def _runs(scale: str, seed: int, reverse: bool = False, **effects) -> tuple[list, tuple]:
    inertia, k_l, k_q, drives = SCALES[scale]
    if reverse:  # every other run pulls the other way
        drives = tuple(d if i % 2 == 0 else -d for i, d in enumerate(drives))
    phys = Physics(inertia, k_l, k_q, **effects)
    return tow_set(phys, seed=seed, drives=drives), (inertia, k_l, k_q)


def _coefficients(doc) -> np.ndarray:
    c = doc["coefficients"]
    return np.array([c[k]["value"] for k in ("inertia", "linear_damping", "quadratic_damping")])


def _assert_close(doc, truth, rel=(0.03, 0.03, 0.03)):
    err = _coefficients(doc) / np.array(truth) - 1
    assert np.all(np.abs(err) < np.array(rel)), f"relative errors {err}"


@pytest.mark.parametrize("scale", list(SCALES))
def test_clean_data_yields_no_effect_and_the_coefficients(scale):
    runs, truth = _runs(scale, seed=21)
    doc = estimate(runs, n_bootstrap=0).to_json()
    assert doc["effects"] == [] and doc["ambiguous"] == []
    _assert_close(doc, truth, rel=(0.01, 0.03, 0.01))
    assert doc["unexplained"]["structured"] is False
    assert not any("structured" in w for w in doc["warnings"])


@pytest.mark.parametrize(
    ("scale", "effect", "value_of_drive", "reverse"),
    [
        ("10kg", "coulomb_friction", 0.04, True),
        ("10kg", "restoring_spring", None, False),
        ("1000kg", "constant_bias", 0.03, False),
        ("1000kg", "cubic_drag", None, False),
    ],
)
def test_single_effect_is_named_with_its_value(scale, effect, value_of_drive, reverse):
    _, _, k_q, drives = SCALES[scale]
    values = {
        "coulomb_friction": ("coulomb", value_of_drive and value_of_drive * drives[1]),
        "constant_bias": ("bias", value_of_drive and value_of_drive * drives[1]),
        "restoring_spring": ("spring", 0.05 * drives[0]),  # 5 % of the small drive per metre
        "cubic_drag": ("cubic", 0.5 * k_q),  # N·s³/m³: a few % of the drag at 0.5 m/s
    }
    field, value = values[effect]
    runs, truth = _runs(scale, seed=22, reverse=reverse, **{field: value})
    doc = estimate(runs, n_bootstrap=0).to_json()
    assert [e["name"] for e in doc["effects"]] == [effect]
    assert doc["effects"][0]["value"] == pytest.approx(value, rel=0.10)
    _assert_close(doc, truth)
    assert doc["rmse_after"] < 0.5 * doc["rmse_before"]


@pytest.mark.parametrize(("scale", "bias_sign"), [("10kg", -1.0), ("1000kg", +1.0)])
def test_dry_friction_with_a_current_is_named_as_a_pair(scale, bias_sign):
    """Opposing (or aiding) effects that no single effect explains: the greedy search's
    blind spot. With reverse runs in the set both are named with their values."""
    drives = SCALES[scale][3]
    coulomb, bias = 0.05 * drives[1], bias_sign * 0.025 * drives[1]
    runs, truth = _runs(scale, seed=23, reverse=True, coulomb=coulomb, bias=bias)
    doc = estimate(runs, n_bootstrap=0).to_json()
    found = {e["name"]: e["value"] for e in doc["effects"]}
    assert set(found) == {"coulomb_friction", "constant_bias"}
    assert found["coulomb_friction"] == pytest.approx(coulomb, rel=0.10)
    assert found["constant_bias"] == pytest.approx(bias, rel=0.10)
    _assert_close(doc, truth)
    assert doc["ambiguous"] == []


def test_one_way_runs_make_friction_and_bias_structurally_ambiguous():
    """Every run moves one way: sign(v) is constant, so the verdict is collinearity on these
    runs, whatever the optimiser does."""
    drives = SCALES["1000kg"][3]
    runs, truth = _runs("1000kg", seed=24, coulomb=0.04 * drives[1])
    doc = estimate(runs, n_bootstrap=0).to_json()
    assert [e["name"] for e in doc["effects"]] == ["coulomb_friction"]
    assert [sorted(g) for g in doc["ambiguous"]] == [["constant_bias", "coulomb_friction"]]
    assert any("reverse tow" in a for a in doc["advice"])
    _assert_close(doc, truth)


@pytest.mark.parametrize("scale", list(SCALES))
def test_a_force_outside_the_library_is_flagged_not_absorbed(scale):
    """A force periodic along the rail (no library effect has that shape)."""
    drives = SCALES[scale][3]
    runs, _ = _runs(scale, seed=25, ripple=0.1 * drives[0], ripple_wavelength=0.4)
    doc = estimate(runs, n_bootstrap=0).to_json()
    assert doc["effects"] == []
    unexplained = doc["unexplained"]
    assert unexplained["structured"] and unexplained["coefficients_possibly_biased"]
    assert unexplained["strongest"] == "position"
    assert unexplained["period"]["domain"] == "position"
    assert unexplained["period"]["value"] == pytest.approx(0.4, rel=0.05)
    assert unexplained["ratio_to_noise_floor"] > 3
    assert any("still structured" in w and "biased" in w for w in doc["warnings"])
    # With the search off the warning says no effect was tried, and asks for the search.
    off = estimate(runs, n_bootstrap=0, search_effects=False).to_json()
    (warning,) = [w for w in off["warnings"] if "structured" in w]
    assert "effect search was off" in warning and "after the effect search" not in warning


def test_one_noise_free_run_claims_no_effect_it_cannot_identify():
    """One run at one force: a bias is an inertia change, a delay of microseconds is timing
    and round-off is no force. Nothing is claimed."""
    t = np.arange(0.0, 6.0, 0.1)
    x = np.where(t > 0.95, 0.1 * (t - 0.95) ** 2, 0.0)  # 10 N on 50 kg, no damping
    doc = estimate([RunData("u", "surge", t, x, 10.0, t_release=0.95)], n_bootstrap=0).to_json()
    assert doc["effects"] == []
    steps = doc["evidence"]["steps"]
    assert "constant_bias" in {
        s["effect"] for s in steps if "not identified by these records" in s["reason"]
    }
