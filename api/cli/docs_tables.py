"""The parameter tables and option lists of the docs, made from the request models:
``python -m api.cli.docs_tables`` rewrites, in each file it is given (default: docs/api.md
and README.md), the table between ``<!-- parameters: package.module.Model -->`` and
``<!-- /parameters -->`` from that model's fields (name, option, type and range, default,
help), and the code span between ``<!-- options: package.module.Model … -->`` and
``<!-- /options -->`` (inline, in a command table's row) with the options of those models
(``[--operator NAME] … [--tag TAG]…``, ``--command C | --force N`` for a model's
``exactly_one_of``), so adding an option to an operation is one edit in its model and a run
of this module. A command's own options, made from no model (``--json``, ``--report``,
``rig serve``'s), are named ``cli:serve`` in the span (``cli:user.add`` for ``rig user
add``): they are read from its click command, where each is declared. ``--check`` only says
which files differ (exit 1), as ``tests/api/test_docs_tables.py`` does.
"""

from __future__ import annotations

import importlib
import re
import sys
from pathlib import Path
from typing import Any

import click
from pydantic import BaseModel

from daq.procedures.flag import Flag
from daq.procedures.procedure_request import required_by_check

#: The files holding tables, from the repository's root.
DOCS = (Path("docs/api.md"), Path("README.md"))
_TABLE = re.compile(
    r"(?P<open><!-- parameters: (?P<model>[\w.]+) -->\n).*?(?P<close><!-- /parameters -->)",
    re.DOTALL,
)
_OPTIONS = re.compile(
    r"(?P<open><!-- options: (?P<models>[\w.: -]+?) -->)`[^`\n]*`(?P<close><!-- /options -->)"
)
#: A span's name of a command without a request model: ``cli:`` and its words, dotted.
_CLI = "cli:"
#: The options a command's span leaves out: said once for every command (README, "Command
#: line": "Commands that touch storage take ``--db URL``").
_SAID_ONCE = frozenset({"db_url"})
_BOUNDS = (("minimum", "≥"), ("exclusiveMinimum", ">"), ("maximum", "≤"), ("exclusiveMaximum", "<"))


def _cell(text: str) -> str:
    """``text`` as one Markdown table cell (``|`` escaped, one line)."""
    return " ".join(str(text).split()).replace("|", "\\|")


def _number(value: float) -> str:
    """``2**53 - 1`` as ``2^53 − 1`` and ``2**62`` as ``2^62`` (an id's bound), other
    integers as they are, 0.5 as 0.5."""
    if isinstance(value, int):
        if value > 10**6 and value & (value - 1) == 0:
            return f"2^{value.bit_length() - 1}"
        if value > 10**6 and value & (value + 1) == 0:
            return f"2^{value.bit_length()} − 1"
        return str(value)
    return f"{value:g}"


def _kind(schema: dict[str, Any], defs: dict[str, Any]) -> str:
    """A field's JSON Schema (``defs``: the model's ``$defs``) as words: ``number ≥ 0, ≤ 42``,
    ``one of csv, json``, ``list of text (≤ 20 items)``."""
    options = [s for s in schema.get("anyOf", [schema]) if s.get("type") != "null"]
    if len(options) != 1:
        return " or ".join(_kind(s, defs) for s in options)
    one = options[0]
    if "$ref" in one:
        one = defs.get(one["$ref"].rsplit("/", 1)[-1], {}) | {
            k: v for k, v in one.items() if k != "$ref"
        }
    if "enum" in one:
        return "one of " + ", ".join(map(str, one["enum"]))
    if "const" in one:
        return str(one["const"])
    kind = {"number": "number", "integer": "integer", "string": "text", "boolean": "true/false",
            "array": "list", "object": "object"}.get(one.get("type", ""), "value")  # fmt: skip
    if kind == "list" and "items" in one:
        kind = f"list of {_kind(one['items'], defs)}"
    bounds = [f"{sign} {_number(one[key])}" for key, sign in _BOUNDS if key in one]
    lengths = [f"≤ {one[k]} {'items' if k == 'maxItems' else 'characters'}"
               for k in ("maxLength", "maxItems") if k in one]  # fmt: skip
    return " ".join([kind, ", ".join(bounds)]).strip() + (
        f" ({', '.join(lengths)})" if lengths else ""
    )


def _flag(model: type[BaseModel], name: str) -> Flag | None:
    return next((m for m in model.model_fields[name].metadata if isinstance(m, Flag)), None)


def _repeats(kind: str, flag: Flag) -> bool:
    """A list field whose option is given once per item (``--tag A --tag B``)."""
    return kind.startswith("list") and flag.parse is flag.when_set is None


#: The unit a field's name ends in (``max_time_s``), as its option's placeholder (``S``).
_UNITS = ("s", "m", "n", "nm", "kg", "rad", "v", "us", "hz")


def _placeholder(name: str, kind: str) -> str:
    """An option's placeholder when its flag has no metavar: the unit its field's name ends
    in (``max_time_s`` → ``S``), ``COLUMN`` for a table's column (``thrust_column``), ``N``
    for a count, else the name (``THRUSTER``)."""
    unit = name.rsplit("_", 1)[-1]
    if "_" in name and unit in _UNITS:
        return unit.upper()
    if "_" in name and unit == "column":
        return "COLUMN"
    return "N" if kind.startswith("integer") else name.upper()


def _required(model: type[BaseModel], name: str) -> bool:
    """Whether field ``name`` must be given: required by the model, or by the rig check
    although its default is ``None`` (``RequiredByCheck``: manual thrust's ``--command``)."""
    return model.model_fields[name].is_required() or required_by_check(model, name)


def _click_word(option: click.Option) -> str:
    """One click option as a synopsis word: ``--host HOST`` (its metavar, else its choices,
    ``FILE`` for a file, ``N`` for a count, else its name), ``[--rtu]`` for an on/off flag,
    ``[--realtime|--no-realtime]`` for a pair, ``…`` after a repeatable one."""
    name = next((o for o in option.opts if o.startswith("--")), option.opts[0])
    if option.is_flag:
        word = "|".join([name, *option.secondary_opts])
    else:
        kind = "integer" if isinstance(option.type, click.types.IntParamType) else ""
        if option.metavar:
            some = option.metavar
        elif isinstance(option.type, click.Choice):
            some = "|".join(map(str, option.type.choices))
        elif isinstance(option.type, click.Path):
            path = option.type
            some = "FILE" if not path.dir_okay else "DIR" if not path.file_okay else "PATH"
        else:
            some = _placeholder(option.name or name.lstrip("-"), kind)
        word = f"{name} {some}"
    return (word if option.required else f"[{word}]") + ("…" if option.multiple else "")


def _command(path: str) -> click.Command:
    """The click command a ``cli:`` name means (``cli:user.add``: ``rig user add``)."""
    from api.cli.main import main as rig  # only to read a command's options

    command: click.Command = rig
    for word in path.removeprefix(_CLI).split("."):
        found = None
        if isinstance(command, click.Group):
            with click.Context(command) as ctx:
                found = command.get_command(ctx, word)
        if found is None:
            raise ValueError(f"{path}: rig has no command {word!r} there")
        command = found
    return command


def command_words(command: click.Command) -> list[str]:
    """The command's own options as synopsis words, in their order: those made from no
    request model (a model's are its span's), but ``--db`` (:data:`_SAID_ONCE`) and hidden
    ones."""
    from api.cli.options import ModelOption  # only to tell a model's options apart

    return [
        _click_word(p)
        for p in command.params
        if isinstance(p, click.Option)
        and not isinstance(p, ModelOption)
        and not p.hidden
        and p.name not in _SAID_ONCE
    ]


def option_list(models: list[type[BaseModel]]) -> str:
    """The options of ``models`` as a command's synopsis, in field order: ``--force N`` when
    required, ``[--notes TEXT]`` when not, ``[--thrusters]`` for an on/off flag and
    ``[--tag TAG]…`` for a repeatable one; ``--kind tow\\|spin`` for a choice without a
    metavar; the fields a model gives exactly one of (its ``exactly_one_of``) as one
    alternative where the first of them is, ``--command C \\| --force N`` (``|`` escaped:
    the list is a Markdown table's cell)."""
    words: list[str] = []
    for model in models:
        schema_of = model.model_json_schema()
        properties, defs = schema_of.get("properties", {}), schema_of.get("$defs", {})
        one_of: tuple[str, ...] = getattr(model, "exactly_one_of", ())
        alternatives: list[str] = []
        where = 0
        for name in model.model_fields:
            flag = _flag(model, name)
            if flag is None:
                continue
            kind = _kind(properties.get(name, {}), defs)
            word = flag.name
            if flag.when_set is None:
                choices = kind.removeprefix("list of ").removeprefix("one of ").split(", ")
                some = "|".join(choices) if "one of " in kind else _placeholder(name, kind)
                word += f" {flag.metavar or some}"
            repeats = "…" if _repeats(kind, flag) else ""
            if name in one_of:
                if not alternatives:  # the group stands where its first field is
                    where = len(words)
                alternatives.append(word + repeats)
                continue
            words.append((word if _required(model, name) else f"[{word}]") + repeats)
        if alternatives:
            words.insert(where, " | ".join(alternatives))
    return " ".join(words).replace("|", "\\|")  # a table cell's | is escaped


def span_options(names: list[str]) -> str:
    """The synopsis a span's ``names`` make: request models' options (:func:`option_list`)
    and ``cli:`` commands' (:func:`command_words`), in the order named."""
    parts = [
        " ".join(command_words(_command(n))).replace("|", "\\|")
        if n.startswith(_CLI)
        else option_list([_model(n)])
        for n in names
    ]
    return " ".join(p for p in parts if p)


def parameter_table(model: type[BaseModel]) -> str:
    """The Markdown table of ``model``'s fields: the query or body field, the command's
    option, its type and range, its default and its help (a list field's option repeats)."""
    schema_of = model.model_json_schema()
    properties, defs = schema_of.get("properties", {}), schema_of.get("$defs", {})
    rows = ["| field | option | type and range | default | what |", "|---|---|---|---|---|"]
    for name, info in model.model_fields.items():
        schema = properties.get(name, {})
        kind = _kind(schema, defs)
        flag = _flag(model, name)
        option = "—" if flag is None else f"`{flag.name}`"
        if flag is not None and _repeats(kind, flag):
            option += " (repeatable)"
        if _required(model, name):
            default = "required"
        elif schema.get("default") in (None, [], {}, ""):
            default = "—"
        else:
            default = f"`{schema['default']}`"
        what = (flag.help if flag is not None and flag.help else None) or info.description or ""
        rows.append(f"| `{name}` | {option} | {_cell(kind)} | {_cell(default)} | {_cell(what)} |")
    return "\n".join(rows) + "\n"


def _model(path: str) -> type[BaseModel]:
    """The model a marker names: a class, or a function returning one (a model the registry
    builds, ``daq.procedures.run_kinds.import_fields``)."""
    module, _, name = path.rpartition(".")
    found = getattr(importlib.import_module(module), name)
    if not isinstance(found, type) and callable(found):
        found = found()
    if not (isinstance(found, type) and issubclass(found, BaseModel)):
        raise ValueError(f"{path} is not a pydantic model")
    return found


def rendered(text: str) -> str:
    """``text`` with every marked table and option list made again from its models."""
    text = _TABLE.sub(lambda m: m["open"] + parameter_table(_model(m["model"])) + m["close"], text)
    return _OPTIONS.sub(
        lambda m: f"{m['open']}`{span_options(m['models'].split())}`" + m["close"], text
    )


def main(argv: list[str]) -> int:
    """Rewrite the tables of the files given (default :data:`DOCS`); ``--check``: exit 1
    naming each file whose tables differ, write nothing."""
    check = "--check" in argv
    files = [Path(a) for a in argv if a != "--check"] or list(DOCS)
    stale = []
    for path in files:
        text = path.read_text(encoding="utf-8")
        new = rendered(text)
        if new != text:
            stale.append(path)
            if not check:
                path.write_text(new, encoding="utf-8")
    for path in stale:
        print(f"{path}: {'differs from its models' if check else 'tables rewritten'}")
    return 1 if check and stale else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
