"""The estimator's words for the driven axes (``estimation.data.driven_axes``) are the
registry's: estimation may not import the rig's code, so its table restates the kind, the
command, the route and the load field of each axis, and this test is what keeps the two
one fact. A run it proposes is one the rig's ``rig`` command and route take as written."""

from __future__ import annotations

import shlex

import pytest

from api.cli.options import request_fields
from api.cli.procedures import KIND_COMMANDS
from daq.procedures.run_kinds import KINDS
from daq.vocabulary import AXES, DRIVEN_KINDS
from estimation.data.driven_axes import DRIVEN_AXES, driven_axis


def test_every_driven_kind_of_the_registry_has_its_axis_words_in_estimation():
    by_axis = {str(AXES[kind].axis): kind for kind in DRIVEN_KINDS}
    assert set(DRIVEN_AXES) == set(by_axis)
    for axis, words in DRIVEN_AXES.items():
        spec, terms = KINDS[by_axis[axis]], AXES[by_axis[axis]]
        assert (words.kind, words.command, words.route) == (spec.kind, spec.command, spec.route)
        assert (words.load_field, words.load_unit) == (terms.drive_key, terms.drive_unit)
        assert words.travel_field == terms.travel_key


@pytest.mark.parametrize("axis", sorted(DRIVEN_AXES))
@pytest.mark.parametrize("drive", ["weight", "thrusters"])
@pytest.mark.parametrize("travel", [None, 1.5])
def test_a_proposed_command_line_is_the_request_body_the_route_takes(axis, drive, travel):
    """``rig tow --force -2.5 --thrusters`` (``--max-distance 1.5``: a run the planner stops
    short) parsed by the ``rig`` command gives the same request as the body proposed for
    ``POST /api/jobs/tow``."""
    words = driven_axis(axis)
    spec = KINDS[words.kind]
    assert spec.request is not None
    argv = shlex.split(words.command_line(-2.5, drive, travel))
    assert argv[:2] == ["rig", words.command]
    command = KIND_COMMANDS[words.command.replace("-", "_")]
    parsed = request_fields(spec.request, command.make_context(argv[1], argv[2:]).params)
    from_cli = spec.request.model_validate(parsed).model_dump()
    from_body = spec.request.model_validate(words.request(-2.5, drive, travel)).model_dump()
    assert from_cli == from_body
    assert from_body[words.load_field] == -2.5 and from_body["drive"] == drive
    assert from_body[words.travel_field] == travel


def test_an_axis_nothing_drives_is_refused_naming_the_allowed():
    with pytest.raises(ValueError, match="axis: 'heave' is not allowed; allowed surge, yaw"):
        driven_axis("heave")


def test_a_proposed_release_is_the_request_body_its_route_takes():
    """A released axis's words come from its kind's envelope (the pendulum's: ``rig pendulum
    --angle 0.3``): parsed by the ``rig`` command they give the body proposed for its route."""
    from api.core.rig_envelope import envelope_of
    from daq.config import load_rig

    envelope = envelope_of(load_rig())
    (released,) = [r for a in envelope.axes if (r := envelope.released(a.axis)) is not None]
    (test,) = [c for c in envelope.candidates(released.axis) if c.load == released.max_amplitude]
    spec = KINDS[test.kind]
    assert spec.request is not None and spec.envelope is not None
    argv = shlex.split(test.command)
    assert argv[:2] == ["rig", spec.command] and spec.route == released.command
    command = KIND_COMMANDS[spec.command.replace("-", "_")]
    parsed = request_fields(spec.request, command.make_context(argv[1], argv[2:]).params)
    from_cli = spec.request.model_validate(parsed).model_dump()
    assert from_cli == spec.request.model_validate(test.request()).model_dump()
    assert from_cli[test.field] == released.max_amplitude
