"""``rig estimate`` prints the uncertainty budget (and says Type B is not declared for
imported runs, which carry no rig file); ``rig predict-uncertainty`` predicts U for a planned
sequence from the stored estimate and refuses an axis it has no model for."""

from __future__ import annotations

import json
import re
from pathlib import Path

from tests.estimation.tow.test_report import _numpy_tow
from tests.support.cli import RigCli


def test_estimate_prints_the_budget_and_the_pretest_predicts_u(tmp_path: Path) -> None:
    _numpy_tow(tmp_path / "tow.csv", 1e-5)
    rig = RigCli(tmp_path)
    run = rig("import", "tow.csv", "--kind", "tow", "--force", "24.5").stdout.strip()
    out = rig("estimate", run, "--no-effects", "--report", "report").stdout
    assert "uncertainty (95 %, ITTC/GUM):" in out
    assert "Type B not declared" in out
    assert "inertia = " in out and "dominant:" in out
    # the terminal as report.md: value ± U after the summary's σ and the error, sources last
    lines = out.splitlines()
    at = lines.index("  uncertainty (95 %, ITTC/GUM):")
    assert lines[at - 1].startswith("  RMSE before ")
    assert "  uncertainty by source:" in lines[at + 1 :]
    report = (tmp_path / "report" / "report.md").read_text()
    # value ± U read beside the summary's σ (the fit's, one of U's sources), the sources last
    heads = [line for line in report.splitlines() if line.startswith("## ")]
    at = heads.index("## Uncertainty (ITTC 7.5-02-01-01 / GUM, 95 %)")
    assert heads[at - 1] == "## Summary" and heads[at + 1] == "## Figures"
    assert heads.index("## Uncertainty budget by source") > heads.index("## Evidence")
    reported = re.search(r"inertia = (.+?) \(k = ", out)
    assert reported, out
    beside = report[report.index(heads[at]) : report.index("## Figures")]
    assert f"| inertia | {reported[1]} | " in beside
    assert "Type B not declared" in beside and "**\n**" not in beside  # a paragraph per note
    # the folder's result.json carries the same budget (a lab tool reads it, not the page)
    doc = json.loads((tmp_path / "report" / "result.json").read_text())
    assert doc["budget"]["coefficients"]["inertia"]["reported"] == reported[1]

    (tmp_path / "plan.toml").write_text(
        'name = "plan"\nrepeats = 2\n[[steps]]\nkind = "tow"\nforce_n = 24.5\n'
        '[[steps]]\nkind = "tow"\nforce_n = 83.3\n'
    )
    data = json.loads(rig("predict-uncertainty", "plan.toml", "--json").stdout)
    inertia = data["axes"]["surge"]["coefficients"]["inertia"]
    assert data["models"]["surge"][0] > 100  # the stored estimate's m + m_a
    assert inertia["expanded_uncertainty"] > 0
    assert {r["source"].split(" ")[0] for r in inertia["rows"]} >= {"hung_mass_kg", "g_m_s2"}
    # two repeats of each step: the repeat campaigns give the repeatability row
    assert any(r["source"].startswith("repeatability (2") for r in inertia["rows"])

    (tmp_path / "spins.toml").write_text('[[steps]]\nkind = "spin"\ntorque_nm = 0.907\n')
    err = rig("predict-uncertainty", "spins.toml", code=2).stderr
    assert "model: got no stored estimate for yaw" in err


def test_the_pretest_predicts_a_sequences_driven_steps_and_leaves_its_releases_out(tmp_path):
    """A pendulum step is planned by campaigns (its kind has an envelope) but driven by no
    load: the pretest, which predicts weight-driven tows and spins, leaves it out."""
    from api.core.pretest import planned_runs
    from daq.config import load_rig

    path = tmp_path / "mixed.toml"
    path.write_text(
        'name = "mixed"\n[[steps]]\nkind = "tow"\nforce_n = 24.5\n'
        '[[steps]]\nkind = "pendulum"\nstart_angle_rad = 0.3\n',
        encoding="utf-8",
    )
    (run,) = planned_runs(load_rig(), path)
    assert run.axis == "surge" and run.drive == 24.5
