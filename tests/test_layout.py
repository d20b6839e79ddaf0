"""The house reads as the design (issues 12 and 21): the layers import only downwards, no
module imports itself through others at run time, the data path imports no device or
procedure code, no module reaches into another package's private names, and no module is
over 400 lines.

Layers: ``estimation`` (science on arrays) and ``thrusters`` (the controller) import no other
package of ours; ``daq`` (devices, runs, storage) imports no ``api``; ``api`` is the top.
Within ``daq``: the store imports nothing of ``estimation`` (it stores runs; reading other
tools' CSVs is ``daq.csv_import``), and the loader and the store import neither the
procedures nor the thruster driver (what they share is ``thrusters.settings``).
Imports anywhere in a module count, inside functions too; those under ``if TYPE_CHECKING:``
are for the type checker only and do not.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("daq", "thrusters", "estimation", "api")
#: What each package may import of ours (besides itself).
ALLOWED = {
    "estimation": set(),
    "thrusters": set(),
    "daq": {"estimation", "thrusters"},
    "api": {"daq", "estimation", "thrusters"},
}
#: Modules that may not import (a prefix of) these, besides the layers above.
FORBIDDEN = {
    "daq.store": ("estimation", "daq.procedures", "thrusters.driver"),
    "daq.run_data": ("daq.procedures", "thrusters.driver"),
}
#: Private imports across packages not yet removed: the module importing, and who removes it.
PRIVATE_PENDING = {
    "api.http.schemas": "registry (the request models become one registry entry)",
}
MAX_LINES = 400


def _modules() -> dict[str, Path]:
    out = {}
    for top in PACKAGES:
        for path in sorted((ROOT / top).rglob("*.py")):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            out[name.removesuffix(".__init__")] = path
    return out


MODULES = _modules()


def _runtime_imports(tree: ast.Module) -> list[str]:
    """Dotted names imported anywhere (functions included), minus TYPE_CHECKING blocks."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip |= {id(n) for child in node.body for n in ast.walk(child)}
    names = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names += [f"{node.module}.{a.name}" for a in node.names]
    return names


def _resolve(name: str) -> str | None:
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        targets = {_resolve(n) for n in _runtime_imports(ast.parse(path.read_text("utf-8")))}
        graph[name] = {t for t in targets if t and t != name and not name.startswith(t + ".")}
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def _against_the_layers(graph: dict[str, set[str]]) -> list[str]:
    wrong = []
    for name, targets in graph.items():
        top = name.split(".")[0]
        for target in targets:
            other = target.split(".")[0]
            if other != top and other not in ALLOWED[top]:
                wrong.append(f"{name} imports {target}")
    return sorted(wrong)


def test_layers_import_only_downwards():
    wrong = _against_the_layers(_graph())
    assert not wrong, "imports against the layers:\n" + "\n".join(wrong)


def test_an_import_against_the_layers_is_found():
    graph = {
        "estimation.data.csv_dialect": {"daq.vocabulary", "estimation.data.window"},
        "thrusters.driver": {"api.core.jobs"},
        "daq.run_data": {"estimation.data.runs", "api.http.app"},
        "api.cli.main": {"daq.store", "estimation.axis", "thrusters.settings"},
    }
    assert _against_the_layers(graph) == [
        "daq.run_data imports api.http.app",
        "estimation.data.csv_dialect imports daq.vocabulary",
        "thrusters.driver imports api.core.jobs",
    ]


def test_no_module_imports_itself_through_others():
    assert not _cycles(_graph()), f"import cycles: {_cycles(_graph())}"


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _forbidden_edges(graph: dict[str, set[str]]) -> list[str]:
    """Each module under a ``FORBIDDEN`` owner that reaches a banned module, directly or
    through others, with the chain of imports (a contract is broken through a middle
    module as much as by a direct import)."""
    wrong = []
    for name in sorted(graph):
        for owner, banned in FORBIDDEN.items():
            if name != owner and not name.startswith(owner + "."):
                continue
            came_from: dict[str, str] = {name: ""}
            todo = [name]
            while todo:
                node = todo.pop(0)
                if any(node == b or node.startswith(b + ".") for b in banned):
                    chain = [node]
                    while came_from[chain[-1]]:
                        chain.append(came_from[chain[-1]])
                    wrong.append(" → ".join(reversed(chain)))
                    continue
                for target in sorted(graph.get(node, ())):
                    if target not in came_from:
                        came_from[target] = node
                        todo.append(target)
    return sorted(wrong)


def test_the_data_path_imports_no_procedure_driver_or_estimation_code():
    wrong = _forbidden_edges(_graph())
    assert not wrong, "forbidden imports:\n" + "\n".join(wrong)


def test_forbidden_edges_are_found_directly_and_through_other_modules():
    graph = {
        "daq.store.csvio": {"estimation.data.csv_dialect", "daq.store.run_records"},
        "daq.store.run_records": set(),
        "daq.run_data": {"daq.procedures.thruster_drive", "daq.middle", "thrusters.settings"},
        "daq.middle": {"thrusters.driver"},
        "daq.run_database": {"daq.procedures.axis_steps"},  # a name that only starts like one
    }
    assert _forbidden_edges(graph) == [
        "daq.run_data → daq.middle → thrusters.driver",
        "daq.run_data → daq.procedures.thruster_drive",
        "daq.store.csvio → estimation.data.csv_dialect",
    ]


def _package_of(module: str) -> str:
    """The package a module is in (``daq.store.csvio`` → ``daq.store``; a package's own
    ``__init__`` is in itself)."""
    path = MODULES.get(module)
    if path is not None and path.name == "__init__.py":
        return module
    return module.rpartition(".")[0] or module


def _private_imports(name: str, tree: ast.Module) -> list[str]:
    """``from other.package.module import _name`` in ``name``, where the module imported
    from is in another package (a leading underscore is that package's own business)."""
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.ImportFrom) and node.module and node.level == 0):
            continue
        if node.module.split(".")[0] not in PACKAGES:
            continue
        if _package_of(node.module) == _package_of(name):
            continue
        found += [
            f"{name} imports {node.module}.{a.name}"
            for a in node.names
            if a.name.startswith("_") and not a.name.startswith("__")
        ]
    return found


def test_no_private_name_is_imported_across_packages():
    wrong = []
    for name, path in MODULES.items():
        if name not in PRIVATE_PENDING:
            wrong += _private_imports(name, ast.parse(path.read_text("utf-8")))
    assert not wrong, "private names imported across packages:\n" + "\n".join(sorted(wrong))


def test_a_private_import_across_packages_is_found():
    source = (
        "from estimation.axis.result import Estimate, _num\n"
        "from estimation.pendulum.data import _own\n"
        "from numpy import _private_of_a_library\n"
    )
    tree = ast.parse(source)
    assert _private_imports("estimation.pendulum.estimate", tree) == [
        "estimation.pendulum.estimate imports estimation.axis.result._num"
    ]
    assert _private_imports("estimation.axis.crosscheck", tree) == [
        "estimation.axis.crosscheck imports estimation.pendulum.data._own"
    ]


def test_no_module_is_over_the_size_limit():
    too_long = [
        f"{name} ({lines} lines)"
        for name, path in MODULES.items()
        if (lines := len(path.read_text("utf-8").splitlines())) > MAX_LINES
    ]
    assert not too_long, (
        f"over {MAX_LINES} lines (split where a module does two things): " + ", ".join(too_long)
    )
