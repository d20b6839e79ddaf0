"""The free-decay kind end to end: ``rig import FILE --kind decay --dof …`` and
``POST /api/runs/import?kind=decay&dof=…``, then ``rig estimate`` / the estimation job with
the single-DOF equation (``estimation.motion``).

Data we did not shape: heave decays integrated by scipy's ``solve_ivp`` (not the rig's
simulator nor the estimator's own integrator) at 10 kg and 1000 kg, and the published KVLCC2
1:68 roll decay (SSPA run 21337, ``../shared/data/real/kvlcc2-roll-decay``).

Rules (issue 20): a synthetic decay with the stiffness given gives the added inertia within
2 % and the damping within 10 % of the truth; KVLCC2 with its published C44 and I44 gives
the added roll inertia within 15 % of 19.0 kg·m² (from the records' periods, README).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from tests.support.cli import RigCli, RigCliText, printed_json
from tests.support.shared_data import shared_file

#: KVLCC2 1:68 (kvlcc2-roll-decay/README.md): I44 = Δ·KXX² kg·m², C44 = Δ·g·GM N·m/rad.
I44, C44, A44 = 115.74281, 821.96, 19.0


def heave_decay(
    path: Path, body_kg: float, seed: int = 1, damping_scale: float = 1.0
) -> dict[str, float]:
    """A heave decay released from 5 % of the body's scale length at t = 1 s, 50 Hz for
    ~12 periods, 0.1 mm noise; returns the truth (added mass, damping, stiffness).
    ``damping_scale``: the linear damping × this (1: 4 % of critical)."""
    added, stiffness = 0.2 * body_kg, 40.0 * body_kg  # ω ≈ 5.8 rad/s at every scale
    damping = damping_scale * 0.04 * 2 * np.sqrt(stiffness * (body_kg + added))
    x0 = 0.05 * (body_kg / 1000.0) ** (1 / 3)
    mass = body_kg + added

    def rhs(_t: float, y: list[float]) -> list[float]:
        return [y[1], -(damping * y[1] + stiffness * y[0]) / mass]

    t_free = np.arange(0.0, 13.0, 0.02)
    sol = solve_ivp(rhs, (0.0, t_free[-1]), [x0, 0.0], t_eval=t_free, rtol=1e-10, atol=1e-12)
    rng = np.random.default_rng(seed)
    t = np.r_[np.arange(0.0, 1.0, 0.02), 1.0 + t_free]
    x = np.r_[np.full(50, x0), sol.y[0]] + 1e-4 * rng.standard_normal(t.size)
    lines = ["t,position"] + [f"{a:.2f},{b:.6f}" for a, b in zip(t, x, strict=True)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return {"added": added, "damping": damping, "stiffness": stiffness, "body": body_kg}


@pytest.fixture
def rig(tmp_path: Path) -> RigCliText:
    return RigCliText(tmp_path)


@pytest.mark.parametrize("body_kg", [10.0, 1000.0])
def test_rig_import_decay_and_estimate_recover_a_synthetic_heave_decay(rig, tmp_path, body_kg):
    truth = heave_decay(tmp_path / "heave.csv", body_kg)
    run_id = rig("import", "heave.csv", "--kind", "decay", "--dof", "heave", "--stiffness",
                 f"{truth['stiffness']:g}", "--known-inertia", f"{body_kg:g}",
                 "--release-time", "1")  # fmt: skip
    shown = printed_json(rig("show", run_id, "--json"))
    assert shown["kind"] == "decay" and shown["parameters"]["dof"] == "heave"
    data = printed_json(rig("estimate", run_id, "--no-effects", "--json"))
    assert data["kind"] == "decay" and data["dof"] == "heave"
    c = data["coefficients"]
    assert c["inertia"]["value"] == pytest.approx(truth["added"], rel=0.02)
    assert c["linear_damping"]["value"] == pytest.approx(truth["damping"], rel=0.10)
    assert c["inertia"]["unit"] == "kg"


def test_rig_import_decay_refuses_what_a_decay_does_not_take(rig, tmp_path):
    heave_decay(tmp_path / "heave.csv", 10.0)
    cases = [
        (["--kind", "decay"], "--dof: missing is not allowed (a free decay names its --dof"),
        (["--kind", "decay", "--dof", "heave", "--force", "3"],
         "--force: not used by a free decay (it has no drive)"),
        (["--kind", "tow", "--force", "3", "--dof", "roll"],
         "--dof: 'roll' is not allowed (allowed heave, surge, sway for a tow"),
        (["--kind", "decay", "--dof", "wobble"], "'wobble' is not one of"),
        (["--kind", "decay", "--dof", "heave", "--stiffness", "-4"], "x>0"),
    ]  # fmt: skip
    for argv, expect in cases:
        err = rig("import", "heave.csv", *argv, code=2)
        assert expect in err and err.count("\n") == 1, (argv, err)


def test_the_published_kvlcc2_roll_decay_imports_and_estimates_over_the_cli(rig):
    path = shared_file("real", "kvlcc2-roll-decay", "kvlcc2_roll_decay_21337.csv")
    run_id = rig("import", str(path), "--kind", "decay", "--dof", "roll", "--stiffness",
                 f"{C44:g}", "--known-inertia", f"{I44:g}", "--release-time", "2.0")  # fmt: skip
    data = printed_json(rig("estimate", run_id, "--no-effects", "--json"))
    inertia = data["coefficients"]["inertia"]
    assert inertia["unit"] == "kg·m²"
    assert inertia["value"] == pytest.approx(A44, rel=0.15)
    text = rig("estimate", run_id, "--no-effects")
    assert text.startswith("roll free decay / output-error from 1 run(s)")
    # the identified inertia is the added one: named so, with the body's own that was given
    assert f"  added inertia (body's own {I44:.6g} given) {inertia['value']:.5g}" in text
    # and so in the uncertainty budget: its summary line and its table's heading
    budget = text[text.index("uncertainty (95 %") :]
    assert budget.count(f"added inertia (body's own {I44:.6g} given) ") == 2
    assert not re.search(r"^\s+inertia\b", budget, re.M)
    # B_e over the swings, in the document's order and unit (N·m·s/rad on roll)
    (line,) = [x for x in text.splitlines() if "equivalent linear damping" in x]
    assert "(N·m·s/rad)" in line and line.count(" at ") == len(data["equivalent_linear_damping"])
    # each amplitude in rad and in degrees, as the damping ratios are named (ζ at 4.14°)
    first = data["equivalent_linear_damping"][0]["amplitude"]
    assert f"at {first:.3g} rad ({np.degrees(first):.3g}°)" in line
    assert data["units"]["position"] == "rad" and re.search(r"RMSE before \S+ rad, after", text)


def test_an_exported_decay_imports_back_from_its_own_header(rig, tmp_path):
    truth = heave_decay(tmp_path / "heave.csv", 10.0, seed=7)
    stiffness = f"{truth['stiffness']:g}"
    first = rig("import", "heave.csv", "--kind", "decay", "--dof", "heave", "--stiffness",
                stiffness, "--known-inertia", "10", "--release-time", "1")  # fmt: skip
    rig("export", first, "-o", "back.csv")
    again = RigCli(tmp_path)("import", "back.csv")  # no flags: its header says it all
    assert "from the file's header: kind decay, dof heave" in again.stderr
    second = again.stdout.strip()
    one, two = (printed_json(rig("show", r, "--json"))["parameters"] for r in (first, second))
    for name in ("dof", "stiffness", "known_inertia", "release_time_s"):
        assert two[name] == one[name], name
    fits = [printed_json(rig("estimate", r, "--no-effects", "--json")) for r in (first, second)]
    a, b = (f["coefficients"]["inertia"]["value"] for f in fits)
    assert b == pytest.approx(a, rel=1e-6)


def test_rig_estimate_report_of_a_decay_shows_the_fit_and_its_residual(rig, tmp_path):
    """``--report DIR`` on a free decay (issue 20: the report works for every record that
    estimates): report.md with the coefficients and the evidence, the figure, and the
    residual plotted is the fit's own (its RMS is the result's rmse_after)."""
    import json

    truth = heave_decay(tmp_path / "heave.csv", 10.0, seed=3)
    run_id = rig("import", "heave.csv", "--kind", "decay", "--dof", "heave", "--stiffness",
                 f"{truth['stiffness']:g}", "--known-inertia", "10")  # fmt: skip
    rig("estimate", run_id, "--report", "out")
    out = tmp_path / "out"
    names = sorted(p.name for p in out.iterdir())
    assert names == ["decay.png", "decay.svg", "report.md", "result.json"]
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "# Free decay of heave" in md and "![" in md
    assert "| added mass (body's own 10 given) |" in md  # the identified inertia's row
    budget = md[md.index("## Uncertainty") :]  # and its budget, the summary row and heading
    assert "| added mass (body's own 10 given) |" in budget
    assert "### added mass (body's own 10 given): " in budget
    assert "| inertia |" not in md and "### inertia" not in md
    doc = json.loads((out / "result.json").read_text(encoding="utf-8"))
    assert doc["coefficients"]["inertia"]["value"] == pytest.approx(truth["added"], rel=0.02)
    rmse = f"| RMSE before → after | {doc['rmse_before']:.3g} → {doc['rmse_after']:.3g} | m |"
    assert rmse in md
