"""The docs' parameter tables and the command table's option lists are made from the request
models (``api.cli.docs_tables``), so an option added to a model reaches the docs by running
the generator, never by a hand edit."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, ClassVar, Literal

import click
from pydantic import BaseModel, Field

from api.cli.docs_tables import DOCS, command_words, option_list, parameter_table, rendered
from api.cli.main import main
from api.cli.options import model_options
from api.core.estimation_request import EstimationRequest
from api.core.sixdof import SimulateRequest
from daq.procedures.flag import Flag
from daq.procedures.procedure_request import RequiredByCheck, RunMetadataIn
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


class _Either(BaseModel):
    exactly_one_of: ClassVar[tuple[str, ...]] = ("command", "force_n")

    thrust_column: Annotated[str, Flag("--thrust-column")] = "2"
    command: Annotated[float | None, Flag("--command", metavar="C")] = None
    force_n: Annotated[float | None, Flag("--force")] = None
    angle_rad: Annotated[float | None, Flag("--angle"), RequiredByCheck()] = None


def test_an_option_list_shows_alternatives_and_what_the_rig_check_requires():
    """The fields a model gives exactly one of are one alternative, unbracketed, where the
    first of them is; a field the rig check requires is unbracketed though its default is
    None (and its table row says required); a column's placeholder is COLUMN."""
    assert (
        option_list([_Either]) == "[--thrust-column COLUMN] --command C \\| --force N --angle RAD"
    )
    assert parameter_table(_Either).splitlines()[-1].split(" | ")[3] == "required"


@click.command()
@click.option("--rig", "rig_file", metavar="FILE")
@click.option("--scenario", type=click.Path(dir_okay=False))
@click.option("--db", "db_url", metavar="URL")
@click.option("--port", type=click.IntRange(0, 65535), default=8000)
@click.option("--host", default="127.0.0.1")
@click.option("--role", type=click.Choice(["operator", "viewer"]), required=True)
@click.option("--allow-host", "allow_hosts", multiple=True, metavar="NAME")
@click.option("--open-read", is_flag=True)
@click.option("--realtime/--no-realtime", default=True)
@click.option("--secret", hidden=True)
def _serve_like(**_: object) -> None:
    """A command without a request model."""


def test_a_command_without_a_model_has_its_options_read_from_its_click_command():
    """``cli:serve`` in a span: each option as click declares it (its metavar, else its
    choices, FILE, N or its name), but ``--db`` (said once for every command) and hidden
    ones; a hand-written copy of ``rig serve``'s had lost --ask-operator and --realtime."""
    assert command_words(_serve_like) == [
        "[--rig FILE]", "[--scenario FILE]", "[--port N]", "[--host HOST]",
        "--role operator|viewer", "[--allow-host NAME]…", "[--open-read]",
        "[--realtime|--no-realtime]",
    ]  # fmt: skip
    row = next(r for r in (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
               if r.startswith("| `rig serve`"))  # fmt: skip
    assert "<!-- options: cli:serve -->" in row and "--realtime\\|--no-realtime" in row


_SPAN = re.compile(r"<!-- options: [\w.: -]+ -->`[^`\n]*`<!-- /options -->")


def _command(words: list[str]) -> click.Command:
    """The command ``rig WORDS…`` names (a group's subcommand when it is one)."""
    command: click.Command = main
    for word in words:
        if not isinstance(command, click.Group):
            break
        with click.Context(command) as ctx:
            found = command.get_command(ctx, word)
        assert found is not None, f"no command rig {' '.join(words)}"
        command = found
    return command


def _listed_by_hand(cell: str) -> list[tuple[click.Command, str]]:
    """(command, option) for each option a command table's first cell lists by hand,
    outside the generated spans: in a synopsis (`rig thrust --command U`) or bracketed after
    one (`[--json]`, `[-o FILE]`, the option of the synopsis before it)."""
    listed = []
    command = None
    for span in re.findall(r"`([^`]*)`", _SPAN.sub("`<generated>`", cell)):
        if span.startswith("rig "):
            command = _command(re.findall(r"(?<!-)\b[a-z][\w-]*", span.removeprefix("rig ")))
            listed += [(command, o) for o in re.findall(r"(?<![\w-])--?[a-z][\w-]*", span)]
        elif command is not None:
            listed += [(command, o) for o in re.findall(r"\[(--?[a-z][\w-]*)", span)]
    return listed


def test_the_hand_check_finds_an_option_in_a_synopsis_or_after_it():
    cell = "`rig hold --user NAME` <!-- options: cli:hold -->`[--x]`<!-- /options --> `[-o F]`"
    assert [(c.name, o) for c, o in _listed_by_hand(cell)] == [("hold", "--user"), ("hold", "-o")]


def test_no_command_row_lists_an_option_by_hand():
    """Every option a command's row shows is generated: a model's from the model (a
    hand-written copy had kept ``rig sixdof --commands … | --force …``, both may be given,
    and lost ``--dt``), the command's own (``--json``, ``--user``, ``--report``) from its
    click declaration (``cli:NAME`` in the span; ``rig runs`` had not listed ``--json``)."""
    for path in DOCS:
        for row in (ROOT / path).read_text(encoding="utf-8").splitlines():
            if not row.startswith("| `rig "):  # a command's row (not a route's)
                continue
            listed = [(c.name, o) for c, o in _listed_by_hand(row.split(" | ")[0])]
            assert not listed, f"{path}: {listed} by hand: name the model or cli:NAME in a span"


def test_a_command_s_own_options_are_read_apart_from_its_models():
    """``cli:NAME`` lists the options declared on the command, not those its request
    models make (their spans list them, with alternatives a click option cannot say)."""
    command = click.Command("toy", params=[*model_options(_Choice)], callback=None)
    assert command_words(command) == []
    command.params.append(click.Option(["--json", "as_json"], is_flag=True))
    assert command_words(command) == ["[--json]"]


def test_the_command_table_lists_the_run_metadata_options_from_their_model():
    """Every row of the README's command table naming the run metadata options has them
    made from the model (a hand-written copy had lost ``--salinity`` on ``rig annotate``)."""
    marker = "<!-- options: api.core.run_metadata_query.RunMetadataQuery"
    rows = [r for r in (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
            if r.startswith("| ") and "--operator" in r.split(" | ")[0]]  # fmt: skip
    assert len(rows) >= 2  # the run metadata row and rig annotate's
    for row in rows:
        assert marker in row, row[:80]
