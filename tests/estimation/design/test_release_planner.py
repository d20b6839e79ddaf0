"""The planner's choice of a release (a pendulum's, or any free decay's): from the one engine's
fit of the stored records, each release the rig allows is predicted (``release_outlook``:
``decay_information``'s σ after one more record, the run's duration) and the most progress
on the worst U/|θ| per tank minute wins (``planner._choose_release``). Records: a heave decay
of a 143 kg body integrated by scipy's solve_ivp (independent of the engine's integrator),
20 Hz, 20 µm noise; the envelope allows releases of 5 mm to 0.1 m."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation.design.campaign_state import Campaign, Target
from estimation.design.planner import decide, opening
from estimation.design.planning_envelope import Candidate, ReleaseEnvelope, RigEnvelope
from estimation.design.release_outlook import state_from_release
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.records import Record

MASS, ADDED, STIFFNESS, B1 = 143.0, 114.4, 5720.0, 72.8
RELEASE = ReleaseEnvelope(
    "heave", "decay", "decay", "offset_m", "--offset", "m",
    min_amplitude=0.005, max_amplitude=0.1, max_run_s=30.0, stop_amplitude=0.001,
)  # fmt: skip
ENVELOPE = RigEnvelope((RELEASE,))


def _state(x0: float, b2: float):
    """The planner's state after one record released from ``x0`` (m) of a body with
    quadratic damping ``b2`` (kg/m)."""

    def rhs(_t: float, y: np.ndarray) -> list[float]:
        return [y[1], -(B1 * y[1] + b2 * abs(y[1]) * y[1] + STIFFNESS * y[0]) / (MASS + ADDED)]

    t = np.arange(0.0, 15.0, 0.05)
    sol = solve_ivp(rhs, (0.0, t[-1]), [x0, 0.0], t_eval=t, rtol=1e-11, atol=1e-13)
    x = sol.y[0] + 2e-5 * np.random.default_rng(1).standard_normal(t.size)
    result = estimate_records([Record("a", t, x)], "heave", known_inertia=MASS, stiffness=STIFFNESS)
    return state_from_release(result, (Candidate("heave", x0, "release", RELEASE),), None, RELEASE)


def _next(state, relative: float):
    decision = decide(
        {"heave": state}, ENVELOPE, relative, runs_used=1, minutes_used=1.0, max_runs=5,
        max_minutes=60.0, done={"heave": list(state.recorded)},
    )  # fmt: skip
    return decision


def test_a_poorly_determined_quadratic_damping_buys_the_largest_release():
    """From a 1 cm release K_Q is 41× off a 0.1 % target: only the largest release (where
    |v|·v grows most) brings it under, and that is the choice."""
    state = _state(0.01, b2=572.0)
    assert state.targets == ("inertia", "linear_damping", "quadratic_damping")
    ratios = state.ratios(0.001)
    assert max(ratios, key=ratios.__getitem__) == "quadratic_damping"
    decision = _next(state, 0.001)
    assert decision.stop is None and decision.choice is not None
    choice = decision.choice
    assert choice.test.load == pytest.approx(RELEASE.max_amplitude)
    assert choice.predicted_before == pytest.approx(ratios["quadratic_damping"])
    assert choice.predicted_after < 1.0 < choice.predicted_before
    assert "quadratic_damping" in choice.why and "per tank minute" in choice.why
    # the release is the rig's test in its kind's words
    assert choice.test.request() == {"offset_m": 0.1}
    assert choice.test.command == "rig decay --offset 0.1"


def test_with_no_quadratic_damping_the_shortest_release_that_reaches_the_target_wins():
    """The same body without K_Q: the fit carries M and K_L only, every release brings K_L
    under the target, and the smallest (the shortest run) is chosen — the choice moves with
    what the records leave undetermined, not with the amplitude alone."""
    state = _state(0.01, b2=0.0)
    assert state.targets == ("inertia", "linear_damping")
    decision = _next(state, 0.001)
    assert decision.choice is not None
    assert decision.choice.test.load == pytest.approx(RELEASE.amplitudes()[0])
    durations = [r.duration_s for r in state.releases]
    assert durations[0] == min(durations) and durations[-1] > durations[0]


def test_a_looser_target_buys_a_smaller_release_than_a_tight_one():
    """Progress is capped at the target: with 1 % a mid-sized release already brings K_Q
    under it in a shorter run than the largest."""
    state = _state(0.01, b2=572.0)
    loose, tight = _next(state, 0.01).choice, _next(state, 0.001).choice
    assert loose is not None and tight is not None
    assert RELEASE.amplitudes()[0] < loose.test.load < tight.test.load
    assert loose.predicted_after <= 1.0


def test_an_axis_without_a_record_opens_at_half_the_largest_release_then_stops_at_the_target():
    test = opening(ENVELOPE, "heave", ())
    assert test == Candidate("heave", 0.05, "release", RELEASE)
    assert opening(ENVELOPE, "heave", (test,)) is None
    campaign = Campaign(Target(0.01, ("heave",), 4, 30.0), ENVELOPE)
    first = campaign.next()
    assert first.choice is not None and first.choice.test == test
    assert "opening" in first.choice.why
    state = _state(0.05, b2=572.0)  # released from 5 cm: every ratio under the 1 % target
    assert max(state.ratios(0.01).values()) <= 1.0
    campaign.recorded(first.choice, "a", 16.0, state)
    assert campaign.next().stop == "target"
    (entry,) = campaign.trail
    assert entry["request"] == {"offset_m": 0.05} and entry["after"]["expanded_percent"]


def test_a_release_envelope_refuses_a_range_naming_the_field():
    with pytest.raises(ValueError, match=r"min_amplitude: got 0\.2 rad, allowed: 0 < min_"):
        ReleaseEnvelope("swing", "pendulum", "pendulum", "start_angle_rad", "--angle", "rad",
                        0.2, 0.1, 120.0, 0.005)  # fmt: skip


def test_a_fit_whose_sigma_is_unknown_asks_for_the_largest_release_saying_why():
    """With a σ not known (a coefficient the records do not determine) no release can be
    predicted: the largest is asked for, and the trail says why."""
    from dataclasses import replace

    from estimation.design.planner import choose

    state = _state(0.01, b2=572.0)
    blind = replace(state, std={**state.std, "quadratic_damping": float("nan")}, releases=())
    choice = choose(blind, ENVELOPE, 0.01)
    assert choice is not None and choice.test.load == RELEASE.max_amplitude
    assert choice.why.startswith("σ of quadratic_damping not known")
    assert choice.predicted_before == float("inf")
