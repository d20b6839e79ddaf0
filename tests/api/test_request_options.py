"""``api.cli.options.request_from`` given none of a model's options (or only their
defaults): the model's defaults, and a deferred model (the list filters, ``defer_build``)
left unbuilt, ~0.06 s of CPU off ``rig runs`` (issue 33); anything validating no input
would check is still checked."""

from __future__ import annotations

from typing import Annotated

import pytest
from pydantic import BaseModel, ConfigDict, Field, model_validator

from api.cli.options import request_from
from daq.procedures.flag import Flag


def _window() -> type[BaseModel]:
    """A fresh deferred filter model (a class of its own per test: built or not)."""

    class Window(BaseModel):
        model_config = ConfigDict(defer_build=True)
        since: Annotated[str | None, Field(max_length=3), Flag("--since")] = None
        limit: Annotated[int, Field(ge=1), Flag("--limit")] = 5

    return Window


def test_no_option_given_takes_the_defaults_without_building_the_model():
    window = _window()
    chosen = request_from(window, {"since": None, "limit": None})
    assert not window.__pydantic_complete__  # never built
    assert chosen == window()  # what validating no input gives
    assert chosen.model_fields_set == set()


def test_an_option_left_at_its_default_is_no_input():
    """click hands a page's --limit its default (``rig runs``): still no model built."""
    window = _window()
    chosen = request_from(window, {"since": None, "limit": 5})
    assert not window.__pydantic_complete__
    assert chosen == window()
    assert request_from(window, {"limit": 6}).limit == 6  # another value: validated
    assert window.__pydantic_complete__
    with pytest.raises(SystemExit) as refused:  # not the default's type: validated, refused
        request_from(_window(), {"limit": "five"})
    assert refused.value.code == 2


def test_an_option_given_is_validated():
    window = _window()
    assert request_from(window, {"since": "mon"}).since == "mon"
    with pytest.raises(SystemExit) as refused:
        request_from(window, {"since": "monday"})
    assert refused.value.code == 2


def test_a_model_validator_or_a_required_field_still_checks_no_input():
    class Checked(_window()):  # type: ignore[misc]
        @model_validator(mode="after")
        def never(self) -> Checked:
            raise ValueError("refused")

    class Needs(_window()):  # type: ignore[misc]
        until: Annotated[str, Field(max_length=3), Flag("--until")]

    for model, given in ((Checked, {}), (Needs, {"until": None})):
        with pytest.raises(SystemExit) as refused:
            request_from(model, given)
        assert refused.value.code == 2
