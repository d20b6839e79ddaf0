"""``rig estimate ID --report DIR`` on a tow recorded by another tool, imported without a
release time: the release is found from the motion onset and refined by the fit across a
sample, and the report is written (it failed with "operands could not be broadcast together
with shapes (151,) (150,)" and left DIR empty)."""

from __future__ import annotations

from pathlib import Path

from tests.estimation.tow.test_report import _numpy_tow
from tests.support.cli import RigCli


def test_a_report_for_a_release_found_from_the_motion(tmp_path: Path) -> None:
    _numpy_tow(tmp_path / "tow.csv", 1e-5)
    rig = RigCli(tmp_path)
    run = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5").stdout.strip()
    out = rig("estimate", run, "--no-effects", "--report", "report").stdout
    assert "motion onset, refined by the fit" in out
    written = {p.name for p in (tmp_path / "report").iterdir()}
    assert written >= {"report.md", "fit.png", "fit.svg", "force_residual.png", "result.json"}
