"""No code branches on a run kind's name (issue 21): what differs per kind is an attribute
of its registry entry (``daq.procedures.run_kinds``) or of its axis words (``daq.vocabulary``;
in ``estimation``, which may not import them, ``estimation.data.driven_axes``), so a new
kind is one entry, not an ``if kind == "tow"`` in every face.

Python: a comparison (``==``, ``!=``, ``in``, ``is``) against a run kind's name
(``"tow"``, ``RunKind.SPIN``, ``("tow", "spin")``) in ``daq``, ``api`` or ``estimation``,
outside the modules that define the words. The browser's scripts: a run kind's name in
quotes, or as an object key, in code (comments aside). Modules that still branch are listed
in ``PENDING`` with why; one that no longer does must leave the list (the test says so).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from daq.vocabulary import RunKind

ROOT = Path(__file__).resolve().parents[1]
NAMES = frozenset(str(k) for k in RunKind)
MEMBERS = frozenset(k.name for k in RunKind)
#: Where the kinds' words are defined: the one place that may name them.
DEFINING = {"daq/vocabulary.py", "daq/procedures/run_kinds.py", "estimation/data/driven_axes.py"}
#: Branches not yet removed: the module, and what it decides by the kind's name.
PENDING: dict[str, str] = {}
STATIC = ROOT / "api/http/static"


def _names_a_kind(node: ast.expr) -> bool:
    if isinstance(node, ast.Constant):
        return node.value in NAMES
    if isinstance(node, ast.Attribute):
        return ast.unparse(node.value) == "RunKind" and node.attr in MEMBERS
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return any(_names_a_kind(e) for e in node.elts)
    return False


def kind_branches(source: str) -> list[int]:
    """Lines of ``source`` (Python) comparing something with a run kind's name."""
    return sorted(
        {
            node.lineno
            for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Compare)
            and any(_names_a_kind(n) for n in (node.left, *node.comparators))
        }
    )


_JS_COMMENT = re.compile(r"(^|\s)//.*$")
_KIND_WORDS = "|".join(sorted(NAMES))
#: A kind's name in quotes ("tow", 'tow', `tow`) or as an object key (tow: …).
_JS_KIND = re.compile(rf"""["'`](?:{_KIND_WORDS})["'`]|(?:^\s*|[{{,]\s*)(?:{_KIND_WORDS})\s*:""")


def js_kind_names(source: str) -> list[int]:
    """Lines of ``source`` (a page script) naming a run kind in code."""
    return [
        number
        for number, line in enumerate(source.splitlines(), 1)
        if _JS_KIND.search(_JS_COMMENT.sub("", line))
    ]


def _python_modules() -> dict[str, Path]:
    out = {}
    for top in ("daq", "api", "estimation"):
        for path in sorted((ROOT / top).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel not in DEFINING and "/migrations/" not in rel:
                out[rel] = path
    return out


def test_no_module_branches_on_a_run_kinds_name():
    found = {}
    for rel, path in _python_modules().items():
        lines = kind_branches(path.read_text("utf-8"))
        if lines:
            found[rel] = lines
    new = {rel: lines for rel, lines in found.items() if rel not in PENDING}
    assert not new, f"branches on a run kind's name (make it an attribute of the entry): {new}"
    gone = sorted(set(PENDING) - set(found))
    assert not gone, f"no longer branch on a kind: take them off PENDING: {gone}"


def test_no_page_script_names_a_run_kind():
    found = {}
    for path in sorted(STATIC.glob("*.js")):
        if path.name.endswith(".min.js"):
            continue
        lines = js_kind_names(path.read_text("utf-8"))
        if lines:
            found[path.name] = lines
    assert not found, f"page scripts naming a run kind (read GET /api/kinds): {found}"


def test_a_branch_on_a_kind_is_found():
    python = (
        'if run.kind == "tow" and thrusters:\n    pass\n'
        "x = 1 if kind != RunKind.PENDULUM else 2\n"
        'ok = kind in ("tow", "spin")\n'
        'fine = job.kind == "sequence"\n'
        'words = {"tow": 1}\n'
    )
    assert kind_branches(python) == [1, 3, 4]
    js = (
        '  set("tow", "force_n", l.max_force_n, true);\n'
        "const D = {\n  tow: [1],\n  spin: [2],\n};\n"
        '  if (job.kind === "sequence") return;  // a "tow" in a comment\n'
        "  note = `spin: needs a drum`;\n"
    )
    assert js_kind_names(js) == [1, 3, 4]
