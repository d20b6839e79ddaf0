"""The test planner (``estimation.design``): its information agrees with what the estimator
fits from data we did not make (scipy ``solve_ivp`` runs of ``tests.estimation.synth``), it
stays within the rig, goes the other way after one-way runs, chooses the run that separates
friction from bias, and stops at the target or the budget.

Rule for the information check: the planner's predicted σ = σ_x·√((JᵀJ)⁻¹)ᵢᵢ for the same
runs (σ_x = the encoder step/√12, the synthetic runs' only noise) must agree with the
output-error fit's σ within 0.8 … 1.25. Both are the same linearised least-squares σ; what
may differ is small — the planner's 10 ms Euler step against the generator's 1 kHz RK4, the
generator's 2 ms timestamp jitter — while a missing nuisance (the per-run offset made the
planner 2× optimistic) or a wrong inertia term is off by far more.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimation import estimate
from estimation.design.campaign_state import MAX_REPEATS, Campaign, Target
from estimation.design.information import predict, predict_lengths
from estimation.design.planner import BASE, AxisState, choose, decide, planned_terms
from estimation.design.planning_envelope import AxisEnvelope, Candidate, RigEnvelope
from tests.estimation.synth import SURGE_TRUTH, YAW_TRUTH, tow_set

SURGE = AxisEnvelope("surge", 100.0, 5.5, 5.3, max_rate=1.0)
YAW = AxisEnvelope("yaw", 5.0, 37.7, 37.7, max_rate=3.0, drum_radius_m=0.0926)
RIG = RigEnvelope((SURGE, YAW), g=9.8)
QUANTUM = 1e-4  # the synthetic encoder step: white position noise of QUANTUM/√12


@pytest.mark.parametrize("share", [1.0, 0.25])
@pytest.mark.parametrize(
    ("axis", "truth", "drives", "env"),
    [
        ("surge", SURGE_TRUTH, (24.5, 83.3), SURGE),
        ("yaw", YAW_TRUTH, (0.907, 2.269), YAW),
    ],
)
def test_predicted_sigma_agrees_with_the_fit_on_independent_runs(axis, truth, drives, env, share):
    """To the end of travel and stopped short (a quarter of it: the planner offers such runs,
    ``RigEnvelope.run_lengths``, and must not find them more informative than they are)."""
    travel = env.travel * share
    runs = tow_set(
        axis=axis, seed=3, drives=drives, quantum=QUANTUM, travel_limit=travel, duration_s=120.0
    )
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    theta = np.array([*truth, 0.0, 0.0])
    short = None if share == 1.0 else travel
    tests = [Candidate(axis, d, travel=short) for d in drives]
    info = sum(predict(theta, env, t, 9.8).information for t in tests)
    sigma_x = QUANTUM / np.sqrt(12)
    predicted = sigma_x * np.sqrt(np.diag(np.linalg.inv(info[:3, :3])))
    fitted = np.array(
        [result.coefficients[n].std for n in ("inertia", "linear_damping", "quadratic_damping")]
    )
    ratio = predicted / fitted
    assert np.all((ratio > 0.8) & (ratio < 1.25)), (predicted, fitted)


def _state(recorded, ambiguous=(), std=(0.5, 0.5, 2.0), axis="surge", **budget) -> AxisState:
    values = dict(zip(("inertia", "linear_damping", "quadratic_damping"), SURGE_TRUTH, strict=True))
    return AxisState(
        **budget,
        axis=axis,
        values=values,
        std=dict(zip(values, std, strict=True)),
        correlation={},
        ambiguous=tuple(ambiguous),
        rmse=3e-5,
        recorded=tuple(recorded),
    )


def test_after_one_way_runs_the_next_goes_the_other_way_within_the_rig():
    choice = choose(_state([Candidate("surge", 100.0)]), RIG, 0.01)
    assert choice is not None and choice.test.load < 0
    assert choice.test.load >= -100.0 and RIG.allows("surge", choice.test.load)
    assert "one way" in choice.why


def test_friction_vs_bias_ambiguity_picks_a_reverse_run_that_separates_them():
    recorded = [Candidate("surge", 100.0), Candidate("surge", 45.0)]
    state = _state(recorded, ambiguous=[("coulomb_friction", "constant_bias")])
    choice = choose(state, RIG, 0.01)
    assert choice is not None and choice.test.load < 0
    assert "not yet separated" in choice.why


def test_suspected_dry_friction_buys_the_slow_run_that_separates_it_from_linear_damping():
    """The dry-friction campaign after a fast tow each way: the estimator could not tell
    friction (and a bias) from K_L. The planner judges candidates with them in its model,
    so it runs a slow tow (friction is a larger share of the drag there), not another fast
    one predicted from a model without them (main ran −100 N, then −30 N anyway)."""
    recorded = [Candidate("surge", 100.0), Candidate("surge", -67.3)]
    suspected = [("constant_bias", "linear_damping"), ("coulomb_friction", "linear_damping")]
    state = _state(recorded, ambiguous=suspected, std=(0.77, 0.33, 0.67))
    assert set(planned_terms(state)) == {*BASE, "coulomb_friction", "constant_bias"}
    choice = choose(state, RIG, 0.01)
    assert choice is not None and abs(choice.test.load) < 0.35 * SURGE.max_load
    assert choice.predicted_after > 1.0  # honest: one run does not pin five terms to 1 %


def test_with_type_b_above_the_target_runs_are_judged_on_what_they_can_change():
    """A campaign out of reach measures on only to settle its models: with the floor inside
    U every candidate's progress is nearly nil and the fastest tow won; judged on the Type A
    part it is the slow run it would choose without the tolerance. Its reported prediction
    keeps the Type B part."""
    recorded = [Candidate("surge", 100.0), Candidate("surge", -67.3)]
    suspected = [("constant_bias", "linear_damping"), ("coulomb_friction", "linear_damping")]
    state = _state(recorded, ambiguous=suspected, std=(0.77, 0.33, 0.67))
    stuck = AxisState(**{**state.__dict__, "type_b": {"inertia": 0.2 * SURGE_TRUTH[0]}})
    assert stuck.floor(0.01)["inertia"] > 1.0
    choice, free = choose(stuck, RIG, 0.01), choose(state, RIG, 0.01)
    assert choice is not None and free is not None and choice.test == free.test
    assert abs(choice.test.load) < 0.35 * SURGE.max_load
    assert choice.predicted_after >= stuck.floor(0.01)["inertia"]


def test_a_clean_axis_is_planned_on_its_base_model_and_one_way_runs_suspect_friction():
    both_ways = [Candidate("surge", 100.0), Candidate("surge", -50.0)]
    assert planned_terms(_state(both_ways)) == BASE
    found = AxisState(**{**_state(both_ways).__dict__, "values": {
        **_state(both_ways).values, "coulomb_friction": 3.0}})  # fmt: skip
    assert planned_terms(found) == (*BASE, "coulomb_friction")
    one_way = _state([Candidate("surge", 100.0)])
    assert planned_terms(one_way) == (*BASE, "coulomb_friction", "constant_bias")


def test_a_run_stopped_short_is_the_full_runs_beginning_and_is_offered_at_each_length():
    theta = np.array([*SURGE_TRUTH, 0.0, 0.0])
    full = predict(theta, SURGE, Candidate("surge", -20.0), 9.8)
    lengths = RIG.run_lengths(Candidate("surge", -20.0))
    assert [t.travel for t in lengths] == [
        None,
        *(s * SURGE.reverse_travel for s in (0.5, 0.25, 0.125)),
    ]
    for test in lengths[1:]:
        short = predict(theta, SURGE, test, 9.8)
        assert short.duration_s < full.duration_s
        # the rest of the run adds information: full − short is positive semi-definite
        assert np.linalg.eigvalsh(full.information - short.information).min() > -1e-9 * np.trace(
            full.information
        )
    # the planner's one integration per load gives what each length's own integration gives
    for test, once in zip(lengths, predict_lengths(theta, SURGE, lengths, 9.8), strict=True):
        alone = predict(theta, SURGE, test, 9.8)
        assert once.duration_s == alone.duration_s and once.peak_rate == alone.peak_rate
        np.testing.assert_allclose(once.information, alone.information, rtol=1e-12)
    assert "stopped after 0.6625 m" in lengths[3].describe()
    assert lengths[3].request()["max_distance_m"] == 0.6625
    assert lengths[3].command.endswith("--max-distance 0.6625")


def test_a_run_stopped_short_is_chosen_when_it_teaches_more_per_tank_minute():
    """After a fast tow one way the reverse run's worth is its transient (where inertia,
    friction and the bias show apart) more than its steady tail: with the 30 s reset paid
    either way, a tow stopped at half its travel is predicted to teach more per tank minute
    than any run to the end of travel (on the simulated rig: 7.7 s against 13 s)."""
    state = _state([Candidate("surge", 100.0)])
    choice = choose(state, RIG, 0.01)
    assert choice is not None and choice.test.load < 0
    assert choice.test.travel is not None and choice.test.travel < SURGE.reverse_travel
    full = predict(
        np.array([*SURGE_TRUTH, 0.0, 0.0]), SURGE, Candidate("surge", choice.test.load), 9.8
    )
    assert choice.minutes < (full.duration_s + RIG.reset_s) / 60


def test_no_reverse_candidate_on_a_rig_without_one():
    forward_only = RigEnvelope((AxisEnvelope("surge", 100.0, 5.5, None, max_rate=1.0),))
    assert all(c.load > 0 for c in forward_only.candidates("surge"))
    choice = choose(_state([Candidate("surge", 100.0)]), forward_only, 0.01)
    assert choice is not None and 0 < choice.test.load <= 100.0


def test_stops_at_the_target_and_at_the_budget():
    both_ways = [Candidate("surge", 100.0), Candidate("surge", -50.0)]
    met = _state(both_ways, std=(0.1, 0.05, 0.5))  # 2σ/|θ| ≈ 0.14 %, 0.5 %, 0.4 %
    decision = decide({"surge": met}, RIG, 0.01, runs_used=2, minutes_used=2.0, max_runs=10,
                      max_minutes=60.0, done={})  # fmt: skip
    assert decision.stop == "target"
    not_met = _state(both_ways, std=(2.0, 2.0, 5.0))
    decision = decide({"surge": not_met}, RIG, 0.01, runs_used=2, minutes_used=2.0,
                      max_runs=2, max_minutes=60.0, done={})  # fmt: skip
    assert decision.stop == "budget: 2 of 2 runs used"
    decision = decide({"surge": not_met}, RIG, 0.01, runs_used=2, minutes_used=59.9,
                      max_runs=10, max_minutes=60.0, done={})  # fmt: skip
    assert decision.stop is not None and decision.stop.startswith("budget: the next run")
    ambiguous = _state(both_ways, ambiguous=[("coulomb_friction", "constant_bias")],
                       std=(0.1, 0.05, 0.5))  # fmt: skip
    decision = decide({"surge": ambiguous}, RIG, 0.01, runs_used=2, minutes_used=2.0,
                      max_runs=10, max_minutes=60.0, done={})  # fmt: skip
    assert decision.stop is None  # σ met but an ambiguity left: not done


def test_the_target_is_the_expanded_uncertainty_not_the_fit_sigma():
    """A fit whose 2σ meets 1 % is not done while U — the Type A sources beyond the fit σ and
    the declared tolerances' Type B — does not; the planner predicts U with the Type B part
    held, and stops when Type B alone misses the target."""
    both_ways = [Candidate("surge", 100.0), Candidate("surge", -50.0)]
    inertia = SURGE_TRUTH[0]
    met = dict(std=(0.1, 0.05, 0.5))  # 2σ/|θ| well under 1 % on all three
    args = dict(runs_used=2, minutes_used=2.0, max_runs=10, max_minutes=60.0, done={})
    assert decide({"surge": _state(both_ways, **met)}, RIG, 0.01, **args).stop == "target"
    # Type A twice the fit σ on the inertia (repeatability, release timing): U misses 1 %
    wider = _state(both_ways, **met, type_a_scale={"inertia": 0.006 * inertia / 0.1})
    assert wider.ratios(0.01)["inertia"] > 1.0
    assert decide({"surge": wider}, RIG, 0.01, **args).stop is None  # measure on
    # the tolerances alone give U = 1.4 % of the inertia: no run the planner can choose
    # brings U under 1 %, so it stops and names the tolerance to tighten
    stuck = _state(
        both_ways,
        std=(2.0, 2.0, 5.0),
        type_b={"inertia": 0.007 * inertia},
        type_b_source={"inertia": "hung_mass_kg (±0.005 kg, rectangular)"},
    )
    assert stuck.floor(0.01)["inertia"] == pytest.approx(1.4)
    choice = choose(stuck, RIG, 0.01)
    assert choice is not None and choice.predicted_after >= 1.4  # predicted with it held
    assert decide({"surge": stuck}, RIG, 0.01, **args).stop == (
        "target out of reach: on surge the declared tolerances alone give inertia U = 1.4 % "
        "of its value, above the 1 % target, and more runs do not shrink them (dominant: "
        "hung_mass_kg (±0.005 kg, rectangular)); declare that tolerance tighter if it can "
        "be, or set a target above it"
    )
    # while the fit is ambiguous its floor is judged at coefficients that may be far off:
    # measure on until the estimator tells its models apart, then stop out of reach
    unsure = AxisState(**{**stuck.__dict__, "ambiguous": (("coulomb_friction", "linear_damping"),)})
    decision = decide({"surge": unsure}, RIG, 0.01, **args)
    assert decision.stop is None and decision.choice is not None
    one_way = AxisState(**{**stuck.__dict__, "recorded": (Candidate("surge", 100.0),)})
    decision = decide({"surge": one_way}, RIG, 0.01, **args)  # friction and bias one constant
    assert decision.stop is None and decision.choice is not None
    assert decision.choice.test.load < 0
    # within reach (Type B alone 0.8 %), the campaign measures on
    reachable = _state(both_ways, std=(2.0, 2.0, 5.0), type_b={"inertia": 0.004 * inertia})
    assert decide({"surge": reachable}, RIG, 0.01, **args).stop is None


def test_an_axis_the_rig_cannot_test_is_refused_naming_the_field():
    tow_only = RigEnvelope((SURGE,))
    with pytest.raises(ValueError, match="axes: the rig cannot test yaw"):
        Campaign(Target(0.01, ("surge", "yaw")), tow_only)
    with pytest.raises(ValueError, match="target: got 0, allowed: 0 < target < 1"):
        Target(0.0)


def test_a_damaged_run_is_repeated_not_booked_and_given_up_after_max_repeats():
    campaign = Campaign(Target(0.01, ("surge",)), RigEnvelope((SURGE,)))
    opening = campaign.next().choice
    assert opening is not None
    for n in range(1, MAX_REPEATS + 1):
        entry = campaign.repeat(opening, f"run{n}", 10.0, "3 samples left out")
        assert entry is not None and entry["repeated"] and entry["n"] == n
        assert entry["why"] == f"repeated, not fitted: run run{n}: 3 samples left out"
        assert campaign.next().choice == opening  # the same test again, not a new plan
    assert campaign.runs_used == 0 and campaign.minutes_used > 0  # tank time spent, no fit
    assert campaign.repeat(opening, "run9", 10.0, "a 0.7 s hole") is None
    assert campaign.outcome is not None and "damaged 3 times in a row" in campaign.outcome


def test_an_axis_whose_models_are_not_told_apart_is_measured_before_one_out_of_reach():
    """The stop "out of reach" waits until every axis's models are told apart, so the next
    run goes to the one-way surge, not to yaw, whose K_L U the tolerances alone hold at
    32 %: no run shrinks that, and ranked on it yaw took every choice until the budget ran
    out (the clean campaign with the rig file's tolerances, ten spins at 5 N·m)."""
    args = dict(runs_used=3, minutes_used=3.0, max_runs=12, max_minutes=60.0, done={})
    both_ways = [Candidate("yaw", 5.0), Candidate("yaw", -3.365)]
    yaw = _state(both_ways, axis="yaw", std=(2.0, 2.0, 5.0),
                 type_b={"linear_damping": 0.16 * SURGE_TRUTH[1]})  # fmt: skip
    assert yaw.floor(0.01)["linear_damping"] > 30
    surge = _state([Candidate("surge", 100.0)], std=(2.0, 2.0, 5.0))
    decision = decide({"surge": surge, "yaw": yaw}, RIG, 0.01, **args)
    assert decision.stop is None and decision.choice is not None
    assert decision.choice.test.axis == "surge" and decision.choice.test.load < 0
