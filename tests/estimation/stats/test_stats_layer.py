"""Shared statistics depend on no model (issue 21 item 3): ``estimation.stats`` imports
nothing of ``estimation`` outside itself but ``estimation.report_numbers`` (how a JSON
document writes a number: itself model-free, checked below), so the tow/spin, pendulum and
decay models can all use it and none of them leaks into the others through it."""

from __future__ import annotations

import ast
from pathlib import Path

STATS = Path(__file__).resolve().parents[3] / "estimation" / "stats"
#: Model-free modules outside the package that the statistics may use.
MODEL_FREE = {"estimation.report_numbers"}


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_shared_statistics_import_no_model():
    modules = sorted(STATS.glob("*.py"))
    assert len(modules) >= 4  # diagnostics, fit, identify, selection (a rename fails here)
    wrong = {
        f"{path.name} imports {name}"
        for path in modules
        for name in _imports(path)
        if name.startswith("estimation")
        and not name.startswith("estimation.stats")
        and name not in MODEL_FREE
    }
    assert not wrong, sorted(wrong)
    for name in MODEL_FREE:  # and those import nothing of the estimator themselves
        path = STATS.parent.parent / (name.replace(".", "/") + ".py")
        assert not {n for n in _imports(path) if n.startswith("estimation")}, name
