"""The docs' parameter tables and the command table's option lists are made from the request
models (``api.cli.docs_tables``), so an option added to a model reaches the docs by running
the generator, never by a hand edit."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import BaseModel, Field

from api.cli.docs_tables import DOCS, option_list, parameter_table, rendered
from api.core.estimation_request import EstimationRequest
from api.core.sixdof import SimulateRequest
from daq.procedures.flag import Flag
from daq.procedures.procedure_request import RunMetadataIn
from daq.procedures.run_kinds import RIG_KINDS
from tests.api.test_one_declaration import BODIES, OPERATIONS

ROOT = Path(__file__).resolve().parents[2]


def test_the_committed_tables_are_the_ones_the_models_make():
    for path in DOCS:
        text = (ROOT / path).read_text(encoding="utf-8")
        assert rendered(text) == text, f"{path} differs: run python -m api.cli.docs_tables"


def test_every_operation_declared_once_has_its_table_in_the_api_docs():
    text = (ROOT / "docs/api.md").read_text(encoding="utf-8")
    kinds = [spec.request for spec in RIG_KINDS.values() if spec.request is not None]
    for model in (
        [m for m, *_ in OPERATIONS + BODIES]
        + kinds
        + [EstimationRequest, SimulateRequest, RunMetadataIn]
    ):
        marker = f"<!-- parameters: {model.__module__}.{model.__name__} -->"
        assert marker in text, model.__name__


class _Toy(BaseModel):
    depth_m: Annotated[
        float | None, Field(gt=0, le=12.5, description="Water depth, m."), Flag("--depth")
    ] = None
    tag: Annotated[list[str], Field(max_length=3, description="A tag."), Flag("--tag")] = []
    count: Annotated[int, Field(ge=1, description="How many.")] = 2


def test_a_row_says_the_option_the_range_the_default_and_the_help_of_its_field():
    rows = parameter_table(_Toy).splitlines()[2:]
    assert rows == [
        "| `depth_m` | `--depth` | number > 0, ≤ 12.5 | — | Water depth, m. |",
        "| `tag` | `--tag` (repeatable) | list of text (≤ 3 items) | — | A tag. |",
        "| `count` | — | integer ≥ 1 | `2` | How many. |",
    ]


class _Choice(BaseModel):
    unit: Annotated[Literal["s", "ms"], Field(description="Unit."), Flag("--unit")]
    fast: Annotated[bool, Field(description="Fast."), Flag("--fast", when_set=True)] = False
    repeats: Annotated[int, Field(ge=1, description="Repeats."), Flag("--repeats")] = 1
    label: Annotated[str, Field(description="Label."), Flag("--label")] = "x"


def test_an_option_list_is_the_synopsis_of_its_models_options():
    assert option_list([_Toy]) == "[--depth M] [--tag TAG]…"
    assert option_list([_Choice]) == "--unit s\\|ms [--fast] [--repeats N] [--label LABEL]"


def test_the_command_table_lists_the_run_metadata_options_from_their_model():
    """Every row of the README's command table naming the run metadata options has them
    made from the model (a hand-written copy had lost ``--salinity`` on ``rig annotate``)."""
    marker = "<!-- options: api.core.run_metadata_query.RunMetadataQuery -->"
    rows = [r for r in (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
            if r.startswith("| ") and "--operator" in r.split(" | ")[0]]  # fmt: skip
    assert len(rows) >= 2  # the run metadata row and rig annotate's
    for row in rows:
        assert marker in row, row[:80]
