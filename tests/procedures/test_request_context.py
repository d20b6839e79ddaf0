"""A kind's request model checks itself against the rig file given in pydantic's validation
context (``model_validate(raw, context={"rig": rig})``): without a rig only the types are
checked (the HTTP body), with one the rig's limits are, the rig's defaults fill in, and the
result is the procedure's frozen parameters. Every refusal names the field, the value and
the allowed range on one line."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.procedures.params import ParameterError
from daq.procedures.requests import CalibrationRequest, PendulumRequest, TowRequest
from daq.procedures.run_kinds import RIG_KINDS

RIG = load_rig(DEFAULT_RIG_FILE)  # BENBAM: max_force_n 100, end_of_travel_m 5.5, g 9.8


def test_without_a_rig_only_types_are_checked_and_nothing_is_filled_in():
    body = TowRequest.model_validate({"force_n": 500.0})  # over the rig's limit: not known here
    assert body.force_n == 500.0 and body.max_distance_m is None and body.max_time_s is None
    with pytest.raises(ValidationError):
        TowRequest.model_validate({"force_n": "24.5"})  # strict: a JSON number only


def test_with_the_rig_in_the_context_limits_are_checked_and_defaults_filled():
    params = TowRequest.model_validate({"force_n": 24.5}, context={"rig": RIG})
    assert params.max_distance_m == RIG.geometry.end_of_travel_m
    assert params.max_time_s == 120.0 and params.hung_mass_kg == pytest.approx(2.5)
    with pytest.raises(ValidationError) as caught:
        TowRequest.model_validate({"force_n": 500.0}, context={"rig": RIG})
    (error,) = caught.value.errors()  # the model's checks, each naming its field
    raised = error["ctx"]["error"]
    assert isinstance(raised, ParameterError)
    assert raised.lines() == [
        "force_n: 500.0 is not allowed (allowed 0 < |force_n| ≤ 100 N, rig limit "
        "max_force_n; negative for a reverse test)"
    ]


def test_checked_parameters_are_frozen_and_carry_the_load_applied():
    params = TowRequest.checked({"weight_kg": 1.23456}, RIG)
    assert params.force_n == pytest.approx(1.235 * RIG.rig.g) and params.weight_kg is None
    assert params.requested == {"weight_kg": 1.23456}
    with pytest.raises(ValidationError, match="frozen"):
        params.force_n = 1.0  # type: ignore[misc]
    stored = params.to_json()
    assert stored["kind"] == "tow" and stored["hung_mass_kg"] == pytest.approx(1.235)
    assert "weight_kg" not in stored and "metadata" not in stored


def test_every_problem_is_named_at_once_one_line_each():
    with pytest.raises(ParameterError) as caught:
        TowRequest.checked({"force_n": 0, "max_time_s": 9999.0, "baseline_s": -1.0}, RIG)
    assert [p[0] for p in caught.value.problems] == ["force_n", "max_time_s", "baseline_s"]
    assert all("\n" not in line for line in caught.value.lines())
    assert "allowed 0 < max_time_s ≤ 600 s" in caught.value.lines()[1]


def test_cross_field_rules_read_the_other_fields_and_the_rig():
    with pytest.raises(ParameterError, match=r"stop_amplitude_rad: 0\.2 .*below start_angle"):
        PendulumRequest.checked({"start_angle_rad": 0.2, "stop_amplitude_rad": 0.2}, RIG)
    plain = RIG.model_copy(update={"pendulum": None})
    with pytest.raises(ParameterError, match=r"rig: .* is not allowed \(a rig file with a \["):
        PendulumRequest.checked({"start_angle_rad": 0.2}, plain)
    reverse = TowRequest.checked({"force_n": -24.5}, RIG)
    assert reverse.max_distance_m == pytest.approx(RIG.geometry.reverse_travel)
    sweep = CalibrationRequest.checked({"commands": [0.4, 0.2, 0.6]}, RIG)
    assert sweep.commands == [0.0, 0.2, 0.4, 0.6] and sweep.sweep[:4] == [0.0, 0.2, 0.4, 0.6]


def test_the_json_schema_of_every_rig_kind_is_its_request_and_nothing_derived():
    for spec in RIG_KINDS.values():
        assert spec.request is not None
        props = spec.request.model_json_schema()["properties"]
        assert "hung_mass_kg" not in props and "requested" not in props and "kind" not in props
        assert "metadata" in props


@pytest.mark.parametrize(
    ("raw", "field"),
    [({"reverse": False}, "reverse"), ({"commands": [0.2, 0.4]}, "commands")],
)
def test_a_sweep_the_per_side_curve_could_not_fit_is_refused_before_it_runs(raw, field):
    """The curve needs ``MIN_POINTS_PER_SIDE`` points per side: a forward-only sweep, or two
    commands (three points a side), used to run the whole sweep and then fail in the fit."""
    with pytest.raises(ParameterError) as caught:
        CalibrationRequest.checked(raw, RIG)
    assert [p[0] for p in caught.value.problems] == [field]
    assert CalibrationRequest.checked({"commands": [0.2, 0.4, 0.6]}, RIG).reverse
