"""The house reads as the design (issues 12, 21 and 34): the layers import only downwards,
no module imports itself through others (type-checking imports count: a circle there is
two modules that each need the other's type), the data path imports no device or
procedure code, no module touches another module's private names, storage errors stay
behind the store, and no two modules share a file name unless they are one operation's
faces. Modules are cut along meaning, never at a line count.

Layers: ``estimation`` (science on arrays) and ``thrusters`` (the controller) import no other
package of ours; ``daq`` (devices, runs, storage) imports no ``api``; ``api`` is the top.
Within ``daq``: the store imports nothing of ``estimation`` (it stores runs; reading other
tools' CSVs is ``daq.csv_to_store``), and the loader and the store import neither the
procedures nor the thruster driver (what they share is ``thrusters.settings``).
Imports anywhere in a module count, inside functions too; for the layers and the data path
those under ``if TYPE_CHECKING:`` are for the type checker only and do not, for circles they do.
"""

from __future__ import annotations

import ast
import functools
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
#: Import circles (type-checking imports included) not yet broken, each a sorted list of
#: its modules. Only estimation's may wait here; the lead (issue 34) empties this list.
CIRCLES_PENDING: list[list[str]] = []
#: Private names used across modules not yet removed: ``module: what it touches``. Only
#: estimation's may wait here (the lead, issue 34); daq, thrusters and api have none.
PRIVATE_PENDING: dict[str, str] = {}
#: Underscore names that are a library's public API (SQLAlchemy's ``Row._mapping``, a
#: named tuple's ``_asdict``/``_replace``/``_fields``/``_make``), not anyone's private state.
LIBRARY_UNDERSCORE_API = {"_mapping", "_asdict", "_replace", "_fields", "_make"}
#: Modules sharing a file name with another, not yet renamed (the lead, issue 34).
DUPLICATES_PENDING: set[str] = set()
#: The folders of an operation's faces: ``api/http/routes/X.py``, ``api/cli/X.py`` and
#: ``api/core/X.py`` for the same X are one operation and share its name.
FACES = ("api.http.routes", "api.cli", "api.core")
#: Where storage errors are named: the store translates them (``daq.store.faults``).
STORE = "daq.store"


def _modules() -> dict[str, Path]:
    out = {}
    for top in PACKAGES:
        for path in sorted((ROOT / top).rglob("*.py")):
            name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
            out[name.removesuffix(".__init__")] = path
    return out


MODULES = _modules()


@functools.cache
def _tree(name: str) -> ast.Module:
    """Module ``name`` parsed, once per process (the checks only read it): each parse of
    the 350 modules is 2 s of CPU, and five checks read them all."""
    return ast.parse(MODULES[name].read_text("utf-8"))


def _runtime_imports(tree: ast.Module, *, type_checking: bool = False) -> list[str]:
    """Dotted names imported anywhere (functions included); those in TYPE_CHECKING blocks
    only with ``type_checking``."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if type_checking:
            break
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


def _graph(*, type_checking: bool = False) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {}
    for name in MODULES:
        targets = {_resolve(n) for n in _runtime_imports(_tree(name), type_checking=type_checking)}
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
        "daq.run_data": {"estimation.data.run_arrays", "api.http.app"},
        "api.cli.main": {"daq.store", "estimation.axis", "thrusters.settings"},
    }
    assert _against_the_layers(graph) == [
        "daq.run_data imports api.http.app",
        "estimation.data.csv_dialect imports daq.vocabulary",
        "thrusters.driver imports api.core.jobs",
    ]


def test_no_module_imports_itself_through_others():
    found = _cycles(_graph(type_checking=True))
    new = [c for c in found if c not in CIRCLES_PENDING]
    assert not new, "import circles (TYPE_CHECKING imports count):\n" + "\n".join(
        " ↔ ".join(c) for c in new
    )
    gone = [c for c in CIRCLES_PENDING if c not in found]
    assert not gone, f"broken already: remove from CIRCLES_PENDING: {gone}"


def test_a_circle_through_type_checking_imports_is_found():
    source = "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from daq.b import B\n"
    tree = ast.parse(source)
    assert _runtime_imports(tree) == ["typing.TYPE_CHECKING"]
    assert _runtime_imports(tree, type_checking=True) == ["typing.TYPE_CHECKING", "daq.b.B"]


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


def _own_names(tree: ast.Module) -> set[str]:
    """Underscore names a module declares itself: its functions and classes, names it
    assigns (module, class body) and attributes it sets on ``self``/``cls``."""
    own: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            own.add(node.name)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            own.add(node.id)
        elif (
            isinstance(node, ast.Attribute)
            and isinstance(node.ctx, ast.Store)
            and isinstance(node.value, ast.Name)
            and node.value.id in ("self", "cls")
        ):
            own.add(node.attr)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            own.add(node.target.id)
    return {n for n in own if n.startswith("_")}


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def _private_uses(name: str, tree: ast.Module) -> list[str]:
    """Where module ``name`` touches a private name another module owns: ``x._name`` on
    something other than ``self``/``cls`` for a name it does not declare itself (nor a
    library's public underscore API), ``getattr``/``setattr``/``hasattr``(x, "_name")
    likewise, and ``from other.module import _name``."""
    own = _own_names(tree)
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split(".")[0] in PACKAGES and node.module != name:
                found += [
                    f"{name} imports {node.module}.{a.name}" for a in node.names if _private(a.name)
                ]
            continue
        if isinstance(node, ast.Attribute):
            attr, owner = node.attr, node.value
        elif (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Name)
            and node.func.id in ("getattr", "setattr", "hasattr", "delattr")
            and len(node.args) >= 2
            and isinstance(node.args[1], ast.Constant)
            and isinstance(node.args[1].value, str)
        ):
            attr, owner = node.args[1].value, node.args[0]
        else:
            continue
        if not _private(attr) or attr in own or attr in LIBRARY_UNDERSCORE_API:
            continue
        if isinstance(owner, ast.Name) and owner.id in ("self", "cls"):
            continue
        found.append(f"{name}:{node.lineno} touches {ast.unparse(owner)}.{attr}")
    return found


def test_no_module_touches_another_modules_private_names():
    wrong = []
    for name in MODULES:
        uses = _private_uses(name, _tree(name))
        wrong += [u for u in uses if u.split(":")[0].split(" ")[0] not in PRIVATE_PENDING]
    assert not wrong, "private names used across modules:\n" + "\n".join(sorted(wrong))
    assert all(m.startswith("estimation.") for m in PRIVATE_PENDING), "only estimation waits"


def test_private_uses_across_modules_are_found():
    source = (
        "from estimation.axis.result import Estimate, _num\n"
        "from numpy import _private_of_a_library\n"
        "class Own:\n"
        "    def __init__(self):\n"
        "        self._mine = 1\n"
        "    def same(self, other):\n"
        "        return other._mine + row._mapping['x']\n"
        "def reach(store, runner):\n"
        "    store._finish()\n"
        "    runner._campaigns = getattr(runner, '_campaigns', None)\n"
    )
    assert sorted(_private_uses("api.core.campaign", ast.parse(source))) == [
        "api.core.campaign imports estimation.axis.result._num",
        "api.core.campaign:10 touches runner._campaigns",  # set, and read through getattr
        "api.core.campaign:10 touches runner._campaigns",
        "api.core.campaign:9 touches store._finish",
    ]


def _storage_errors_named(name: str, tree: ast.Module) -> list[str]:
    """Where a module names a database library's errors (``sqlalchemy.exc``, ``sa.exc``,
    ``sqlite3``, ``psycopg``) or SQLAlchemy's ``make_url``: the store's business."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            modules = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            modules = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Attribute) and ast.unparse(node) in ("sa.exc", "sqlalchemy.exc"):
            modules = ["sqlalchemy.exc"]
        else:
            continue
        for module in modules:
            if module.split(".")[0] in ("sqlite3", "psycopg", "psycopg2") or module.startswith(
                ("sqlalchemy.exc", "sqlalchemy.engine.make_url")
            ):
                found.append(f"{name}:{node.lineno} names {module}")
                break
    return found


def test_storage_errors_are_named_only_behind_the_store():
    wrong = []
    for name in MODULES:
        if name != STORE and not name.startswith(STORE + "."):
            wrong += _storage_errors_named(name, _tree(name))
    assert not wrong, "storage errors named outside daq.store:\n" + "\n".join(sorted(wrong))


def test_storage_errors_named_outside_the_store_are_found():
    source = (
        "import sqlalchemy as sa\n"
        "from sqlalchemy.exc import ArgumentError\n"
        "import sqlite3\n"
        "def f():\n"
        "    try:\n"
        "        pass\n"
        "    except sa.exc.OperationalError:\n"
        "        pass\n"
    )
    assert _storage_errors_named("api.cli.common", ast.parse(source)) == [
        "api.cli.common:2 names sqlalchemy.exc",
        "api.cli.common:3 names sqlite3",
        "api.cli.common:7 names sqlalchemy.exc",
    ]


def _same_file_names(modules: list[str]) -> list[str]:
    """Modules whose file name another module has too, but the faces of one operation
    (``FACES``: they may share it); a package's ``__init__`` is not a file name of its own."""
    by_name: dict[str, list[str]] = {}
    for module in modules:
        if MODULES.get(module, Path("x.py")).name != "__init__.py":
            by_name.setdefault(module.rpartition(".")[2], []).append(module)
    wrong = []
    for group in by_name.values():
        if len(group) > 1:
            wrong += [m for m in group if m.rpartition(".")[0] not in FACES]
    return sorted(wrong)


def test_no_two_modules_share_a_file_name_unless_faces_of_one_operation():
    found = _same_file_names(list(MODULES))
    new = [m for m in found if m not in DUPLICATES_PENDING]
    assert not new, "modules sharing a file name (name each for what it does):\n" + "\n".join(new)
    gone = sorted(DUPLICATES_PENDING - set(found))
    assert not gone, f"renamed already: remove from DUPLICATES_PENDING: {gone}"


def test_shared_file_names_are_found_and_faces_allowed():
    modules = [
        "api.cli.runs",
        "api.core.runs",
        "api.http.routes.runs",
        "api.cli.theory",
        "daq.decay_import",
        "estimation.motion.decay_import",
        "daq.store.records",
        "estimation.motion.records",
        "estimation.data.runs_table",
    ]
    assert _same_file_names(modules) == [
        "daq.decay_import",
        "daq.store.records",
        "estimation.motion.decay_import",
        "estimation.motion.records",
    ]
    assert _same_file_names([*modules[:3], "daq.runs"]) == ["daq.runs"]
