"""The ``rig`` command table: every command's module and attribute, so that a command's
module is imported only when it runs, and its short help, read from the source without
importing it, so that ``rig --help`` lists them (importing every command costs seconds of
CPU; the registry's request models alone ~0.4 s). The run kinds' commands and help are the
``command``, ``help`` and ``rank`` literals of each ``SPEC`` in ``daq/procedures/kinds/*.py``,
so a new kind is listed without an edit here; another command's short help is its
function's docstring (``ast`` on its module's text, only for ``rig --help``), so it is
written once, where the command is. tests/api/test_cli_edges.py checks both against the
commands."""

from __future__ import annotations

import ast
import functools
import importlib.util
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

import click

#: The module holding the procedure commands: one per kind the rig runs (derived from its
#: registry entry, ``api.cli.procedures``) and ``rig sequence``.
PROCEDURES_MODULE = "api.cli.procedures"
#: The package whose modules are the run kinds (``daq.procedures.run_kinds`` discovers them).
KINDS_PACKAGE = "daq.procedures.kinds"


def _spec_literals(path: Path) -> dict[str, object] | None:
    """The literal keyword arguments of ``SPEC = KindSpec(...)`` in ``path`` (None when the
    module holds no ``SPEC``); a keyword whose value is not a literal is left out."""
    for node in ast.parse(path.read_text(encoding="utf-8"), str(path)).body:
        if (
            isinstance(node, ast.Assign)
            and any(isinstance(t, ast.Name) and t.id == "SPEC" for t in node.targets)
            and isinstance(node.value, ast.Call)
        ):
            out: dict[str, object] = {}
            for keyword in node.value.keywords:
                if keyword.arg is None:
                    continue
                try:
                    out[keyword.arg] = ast.literal_eval(keyword.value)
                except ValueError:  # a name or a call: present, not a literal
                    out[keyword.arg] = keyword.value
            return out
    return None


@functools.cache
def _kind_helps() -> dict[str, str]:
    """The command of each kind the rig runs (its ``SPEC`` has a ``request`` and a
    ``command``), in rank order: name → its help."""
    spec = importlib.util.find_spec(KINDS_PACKAGE)
    folders = spec.submodule_search_locations if spec is not None else None
    found: list[tuple[int, str, str]] = []
    for folder in folders or ():
        for path in sorted(Path(folder).glob("*.py")):
            literals = _spec_literals(path)
            if literals is None or literals.get("request") is None:
                continue
            command, text, rank = (
                literals.get("command"),
                literals.get("help"),
                literals.get("rank"),
            )
            if isinstance(command, str) and isinstance(text, str) and isinstance(rank, int):
                found.append((rank, command, text))
    return {name: about for _, name, about in sorted(found)}


def kind_commands() -> dict[str, tuple[str, str]]:
    """The command of each kind the rig runs, in rank order: name → (module, attribute)."""
    return {name: (PROCEDURES_MODULE, name.replace("-", "_")) for name in _kind_helps()}


def _docstrings(source: str) -> dict[str, str]:
    """The docstring of each top-level function in ``source``, by name (the module parsed,
    not imported)."""
    return {
        node.name: ast.get_docstring(node) or ""
        for node in ast.parse(source).body
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
    }


def _source(module: str) -> str:
    """The text of ``module``'s file, not imported."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        raise ModuleNotFoundError(module)
    return Path(spec.origin).read_text(encoding="utf-8")


def short_helps() -> dict[str, str]:
    """Every command's short help as click shortens its help (``get_short_help_str(80)``):
    a kind's from its ``SPEC``, another's from its function's docstring."""
    docstrings = {module: _docstrings(_source(module)) for module, _ in OTHER_COMMANDS.values()}
    helps = _kind_helps() | {
        name: docstrings[module].get(attr, "") for name, (module, attr) in OTHER_COMMANDS.items()
    }
    return {
        name: click.Command(name, help=text).get_short_help_str(80) for name, text in helps.items()
    }


#: name → (module, attribute) of the commands that are not a run kind's (their short help is
#: their function's docstring, read by :func:`short_helps`).
OTHER_COMMANDS: dict[str, tuple[str, str]] = {
    "sequence": ("api.cli.procedures", "sequence"),
    "campaign": ("api.cli.campaign", "campaign"),
    "capabilities": ("api.cli.capabilities", "capabilities"),
    "runs": ("api.cli.runs", "runs"),
    "show": ("api.cli.show", "show"),
    "results": ("api.cli.results", "results"),
    "annotate": ("api.cli.metadata", "annotate"),
    "export": ("api.cli.export", "export"),
    "import": ("api.cli.imports", "import_"),
    "import-calibration": ("api.cli.calibration", "import_calibration"),
    "calibrations": ("api.cli.calibration", "calibrations"),
    "thrust": ("api.cli.calibration", "thrust"),
    "jobs": ("api.cli.jobs", "jobs"),
    "queue": ("api.cli.jobs", "queue"),
    "estimate": ("api.cli.estimate", "estimate"),
    "crosscheck": ("api.cli.crosscheck", "crosscheck"),
    "warm-up": ("api.cli.warm_up", "warm_up"),
    "sim": ("api.cli.sim", "sim"),
    "serve": ("api.cli.serve", "serve"),
    "token": ("api.cli.serve", "token"),
    "user": ("api.cli.people", "user"),
    "ack-estop": ("api.cli.people", "ack_estop"),
    "hold": ("api.cli.people", "hold"),
    "release": ("api.cli.people", "release"),
    "sixdof": ("api.cli.sixdof", "sixdof"),
    "sensitivity": ("api.cli.analysis", "sensitivity"),
    "predict-added-mass": ("api.cli.theory", "predict_added_mass"),
    "predict-uncertainty": ("api.cli.uncertainty", "predict_uncertainty"),
    "water": ("api.cli.theory", "water"),
}


class _Commands(Mapping[str, tuple[str, str]]):
    """Every command, the kinds' first: name → (module, attribute). The kinds' are read from
    their modules' text only when asked for (listing, or a name not in ``OTHER_COMMANDS``):
    ``rig runs`` or ``rig show`` parse no kind module (~5 ms of CPU)."""

    def __getitem__(self, name: str) -> tuple[str, str]:
        return OTHER_COMMANDS[name] if name in OTHER_COMMANDS else kind_commands()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(kind_commands() | OTHER_COMMANDS)

    def __len__(self) -> int:
        return len(kind_commands() | OTHER_COMMANDS)


#: Every command, the kinds' first: name → (module, attribute).
COMMANDS: Mapping[str, tuple[str, str]] = _Commands()


def _table_name(function: Callable[..., Any]) -> str:
    """The name ``OTHER_COMMANDS`` gives ``function`` (``ValueError`` when it has none)."""
    # the module's own name, also when it runs as ``python -m api.cli.serve`` (``__main__``)
    # or in a process multiprocessing spawned from that (``__mp_main__``)
    spec = function.__globals__.get("__spec__")
    where = (spec.name if spec is not None else function.__module__, function.__name__)
    for name, entry in OTHER_COMMANDS.items():
        if entry == where:
            return name
    raise ValueError(f"{where[0]}.{where[1]}: not in api.cli.command_table.OTHER_COMMANDS")


def rig_command(**options: Any) -> Callable[[Callable[..., Any]], click.Command]:
    """``click.command`` named as ``OTHER_COMMANDS`` names the function, so a command's name
    is written once, in the table; ``options`` as for ``click.command``."""

    def named(function: Callable[..., Any]) -> click.Command:
        return click.command(_table_name(function), **options)(function)

    return named


def rig_group(**options: Any) -> Callable[[Callable[..., Any]], click.Group]:
    """``click.group`` named as ``OTHER_COMMANDS`` names the function (``rig_command``)."""

    def named(function: Callable[..., Any]) -> click.Group:
        return click.group(_table_name(function), **options)(function)

    return named


def records_runs(name: str, module: str) -> bool:
    """Commands that record or import runs take --operator --water-temp --notes --tag --meta
    (api.cli.metadata), added here once rather than per command: every procedure command
    (one per kind the rig runs, and sequences) and the import."""
    return module == PROCEDURES_MODULE or name == "import"
