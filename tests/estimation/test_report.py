"""Report files: JSON with the documented schema, Markdown with before/after, PNG plots."""

import json

import pytest

from estimation import estimate
from estimation.axis.report import write_report
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def test_report_writes_json_markdown_and_plots(tmp_path):
    runs = tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=21)
    result = estimate(runs, n_bootstrap=5)
    paths = write_report(result, runs, tmp_path / "out")
    names = sorted(p.name for p in paths)
    assert names == ["fit_after.png", "fit_before.png", "report.md", "residuals.png", "result.json"]
    for p in paths:
        if p.suffix == ".png":
            assert p.read_bytes()[:8] == PNG_MAGIC and p.stat().st_size > 10_000
    doc = json.loads((tmp_path / "out" / "result.json").read_text())
    for key in (
        "axis",
        "method",
        "coefficients",
        "effects",
        "ambiguous",
        "rmse_before",
        "rmse_after",
        "runs",
    ):
        assert key in doc
    for key in ("inertia", "linear_damping", "quadratic_damping"):
        assert set(doc["coefficients"][key]) == {"value", "std"}
    assert doc["effects"][0]["name"] == "coulomb_friction" and doc["effects"][0]["unit"] == "N"
    md = (tmp_path / "out" / "report.md").read_text()
    assert "coulomb_friction" in md and "| **all** |" in md and "ambiguous" in md


def test_report_refuses_other_runs(tmp_path):
    runs = tow_set(seed=22)
    result = estimate(runs, n_bootstrap=0, search_effects=False)
    with pytest.raises(ValueError, match="runs: got"):
        write_report(result, runs[:2], tmp_path)


def test_report_for_seed_method(tmp_path):
    runs = tow_set(seed=23)
    result = estimate(runs, method="ls-steady")
    paths = write_report(result, runs, tmp_path)
    assert len(paths) == 5
