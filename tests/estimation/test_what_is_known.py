"""What a result says it knows (issue 31, item 4): the well-determined combinations beside the
raw coefficients, each with its σ and right on records of known truth, the report's first
section, and warnings whose causes and advice fit the kind of record."""

from __future__ import annotations

import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation import estimate
from estimation.axis.tow_report import write_report
from estimation.motion.decay_estimate import estimate_decay
from estimation.motion.decay_report import write_decay_report
from estimation.pendulum.pendulum_estimate import estimate_pendulum
from estimation.pendulum.pendulum_report import pendulum_markdown
from tests.estimation.pendulum_synth import decay as pendulum_decay
from tests.estimation.synth import Physics, tow_set
from tests.support.shared_data import tencate_e1

#: (inertia, K_L, K_Q) of a tow (kg, N·s/m, N·s²/m²) and a spin (kg·m², N·m·s/rad, N·m·s²/rad²).
TRUTH = {"surge": (143.26, 20.16, 241.14), "yaw": (7.97, 0.119, 4.12)}
DRIVES = {"surge": (24.5, 83.3), "yaw": (0.454, 2.269)}


def _by_name(result, prefix: str) -> list:
    return [c for c in result.well_determined if c.name.startswith(prefix)]


@pytest.mark.parametrize("axis", ["surge", "yaw"])
def test_a_tow_or_spin_carries_its_terminal_speeds_and_the_drag_at_each_tested_speed(axis):
    """u∞ solves K_L·u + K_Q·u² = τ; D(u) = K_L·u + K_Q·u² at the speed each run reached:
    each printed with a σ, within 2σ of the truth (the speed in the name is rounded to four
    figures: + 0.1 %)."""
    inertia, k_l, k_q = TRUTH[axis]
    runs = tow_set(Physics(inertia, k_l, k_q), axis=axis, drives=DRIVES[axis], seed=3)
    r = estimate(runs, search_effects=False, n_bootstrap=0)
    speeds, drags = _by_name(r, "terminal speed"), _by_name(r, "drag at")
    assert len(speeds) == len(drags) == 2
    for c, drive in zip(speeds, DRIVES[axis], strict=True):
        truth = (-k_l + np.sqrt(k_l**2 + 4 * k_q * drive)) / (2 * k_q)
        assert c.std is not None and c.std > 0
        assert abs(c.value - truth) <= 2 * c.std + 1e-3 * truth
    for c in drags:
        u = float(c.name.split()[2])
        truth = k_l * u + k_q * u * abs(u)
        assert c.unit == ("N" if axis == "surge" else "N·m")
        assert c.std is not None and c.std > 0
        assert abs(c.value - truth) <= 2 * c.std + 1e-3 * truth
    doc = r.to_json()["well_determined"]
    assert [d["name"] for d in doc] == [c.name for c in r.well_determined]


def _linear_decay(total: float, b1: float, k: float, x0: float, noise: float, seed: int = 1):
    """A free decay from rest at x0 (a hold of 1 s first), integrated by solve_ivp, 20 Hz."""
    t = np.arange(0.0, 1.0 + 12 * 2 * np.pi * np.sqrt(total / k), 0.05)
    free = t[t >= 1.0] - 1.0
    sol = solve_ivp(
        lambda _, y: [y[1], -(b1 * y[1] + k * y[0]) / total],
        (0.0, free[-1]),
        [x0, 0.0],
        t_eval=free,
        rtol=1e-10,
        atol=1e-12,
    )
    x = np.r_[np.full(t.size - free.size, x0), sol.y[0]]
    return t, x + np.random.default_rng(seed).normal(0.0, noise, t.size)


def test_a_decay_carries_its_period_frequency_and_a_damping_ratio_at_each_amplitude(tmp_path):
    """T₀ = 2π√(M/k), ω₀ = 2π/T₀ and ζ = B₁/(2Mω₀) (one value at every amplitude of a
    linear decay), each within 2σ (+ 1 %) of the truth, at the amplitudes B_e is given at;
    the report opens with them."""
    mass = 143.0
    total, k = 1.8 * mass, 40.0 * mass
    b1 = 0.03 * 2 * np.sqrt(total * k)
    t, x = _linear_decay(total, b1, k, x0=0.05, noise=2e-5)
    r = estimate_decay(t, x, "heave", known_inertia=mass, stiffness=k)
    omega = np.sqrt(k / total)
    (frequency,) = _by_name(r, "natural frequency")
    assert frequency.unit == "rad/s" and frequency.std is not None
    assert abs(frequency.value - omega) <= 2 * frequency.std + 0.01 * omega
    ratios = _by_name(r, "damping ratio")
    assert len(ratios) == len(r.equivalent) >= 2
    for c in ratios:
        assert c.std is not None and abs(c.value - 0.03) <= 2 * c.std + 0.01 * 0.03
    write_decay_report(r, r.records, tmp_path)
    md = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert re.findall(r"^## .*", md, re.M)[0] == "## What the record determines"
    assert md.index("natural frequency ω₀") < md.index("| added mass (body's own 143 given)")


def test_a_decays_combinations_carry_u_and_a_stiffness_tolerance_does_not_move_them():
    """The decay's budget gives T₀, ω₀ and ζ a U (k·u_c, ν = n_eff − p) covering the truth;
    a stiffness known to 1 % moves every coefficient by ≈ 1 % (a decay scales M, B and k
    alike) but not T₀ nor ζ: its row there is a tiny share, and the budget's JSON, the
    terminal lines and the markdown list them."""
    from estimation.uncertainty import RecordRefits, uncertainty_budget
    from estimation.uncertainty.text import (
        SOURCE_WIDTH,
        budget_lines,
        budget_sources_markdown,
        budget_summary_markdown,
    )

    mass = 143.0
    total, k = 1.8 * mass, 40.0 * mass
    b1 = 0.03 * 2 * np.sqrt(total * k)
    t, x = _linear_decay(total, b1, k, x0=0.05, noise=2e-5)
    r = estimate_decay(t, x, "heave", known_inertia=mass, stiffness=k)
    budget = uncertainty_budget(r, RecordRefits(r), {"stiffness": 0.01 * k}, r.repeats)
    truth = {
        "natural period T₀": 2 * np.pi * np.sqrt(total / k),
        "natural frequency ω₀": np.sqrt(k / total),
    }
    assert set(budget.combinations) == {c.name for c in r.well_determined}
    for name, c in budget.combinations.items():
        assert np.isfinite(c.expanded) and c.expanded > 0, name
        assert abs(c.value - truth.get(name, 0.03)) <= c.expanded + 0.01 * abs(c.value), name
        (row,) = [row for row in c.rows if row.kind == "B"]
        assert row.share < 0.01, (name, row.share)
    inertia_b = next(row for row in budget.coefficients["inertia"].rows if row.kind == "B")
    assert inertia_b.share > 0.5  # the same tolerance dominates the raw coefficient
    doc = budget.to_json()
    assert set(doc["combinations"]) == set(budget.combinations)
    assert any(line.startswith("  natural period T₀ = ") for line in budget_lines(doc))
    # a source's name longer than the terminal table's column goes on below it, never cut
    tabled = [r["source"] for c in doc["coefficients"].values() for r in c["rows"]]
    assert max(len(name) for name in tabled) > SOURCE_WIDTH  # (encoder quantization's)
    shown: list[str] = []  # each table row's source column, its continuation lines joined
    for line in budget_lines(doc):
        if line.startswith("      ") and shown:
            shown[-1] += " " + line.strip()
        elif line.startswith("    ") and not line.startswith("    source "):
            shown.append(line[4 : 4 + SOURCE_WIDTH].strip())
    assert {" ".join(name.split()) for name in tabled} <= set(shown)
    assert "### natural period T₀: " in "\n".join(budget_sources_markdown(doc))
    # the terminal reads a summary line per quantity first; a budget of one source (the fit
    # alone, nothing declared) is that line again, so it prints no table of its own
    fit_only = budget_lines(uncertainty_budget(r, RecordRefits(r), repeats=r.repeats).to_json())
    summary = [line for line in fit_only if line.startswith("  natural period T₀ ")]
    assert len(summary) == 1 and "±" in summary[0] and "fit" in summary[0]
    assert not any(line.lstrip().startswith("source ") for line in fit_only)
    assert "| natural period T₀ | " in "\n".join(budget_summary_markdown(doc))  # report.md's


def test_a_pendulum_swing_reports_what_it_determines_first():
    """A pendulum's result carries T₀, ω₀ and ζ (the one engine's), and its report opens with
    them and B_e at the same amplitudes, before any raw coefficient."""
    r = estimate_pendulum([pendulum_decay()])
    names = [c.name for c in r.well_determined]
    assert names[:2] == ["natural period T₀", "natural frequency ω₀"]
    assert all(c.std is not None for c in r.well_determined)
    md = pendulum_markdown(r)
    assert re.findall(r"^## .*", md, re.M)[0] == "## What the record determines"
    assert md.index("natural frequency ω₀") < md.index("## Summary")
    # B_e at the amplitudes of the damping ratios, in the same section
    assert r.equivalent and md.index("equivalent linear damping B_e") < md.index("## Sum")


def test_the_settling_sphere_report_opens_with_its_terminal_speed(tmp_path):
    """K_L and K_Q are each unknown, but the report's first section prints the terminal speed
    with its σ, within 1.5 % of the record's own final slope (1.06–2.44 s); no text says
    surge, seed, nan, or asks to enable a search that ran."""
    run = tencate_e1(t_release=0.0, t_end=2.45, dof="heave")
    r = estimate([run], n_bootstrap=0)
    write_report(r, [run], tmp_path)
    md = (tmp_path / "report.md").read_text(encoding="utf-8")
    assert re.findall(r"^## .*", md, re.M)[0] == "## What the record determines"
    row = re.search(r"^\| terminal speed at 0\.0026 N \| (\S+) ± (\S+) \| m/s \|$", md, re.M)
    assert row is not None, md
    speed, sigma = float(row[1]), float(row[2])
    plateau = (run.t >= 1.06) & (run.t <= 2.44)
    slope = np.polyfit(run.t[plateau], run.position[plateau], 1)[0]
    assert abs(speed - slope) <= 0.015 * slope and 0 < sigma < 0.03 * speed
    assert md.index("terminal speed") < md.index("| linear_damping")
    texts = [md, *r.warnings, *r.advice]
    for word in ("surge", "seed 0", "nan", "enable the effect search"):
        assert not any(word in text for text in texts), word


def test_a_decay_that_gains_energy_is_told_causes_a_decay_can_have():
    """A record whose swing grows (something the model lacks puts energy in) holds the
    linear damping at its bound 0: the warning names what can put energy into a decay, and
    no decay text advises a reverse run or a tow, nor uses internal words."""
    mass = 143.0
    total, k = 1.8 * mass, 40.0 * mass
    t, x = _linear_decay(total, -0.004 * 2 * np.sqrt(total * k), k, x0=0.05, noise=2e-5)
    r = estimate_decay(
        t, x, "heave", known_inertia=mass, stiffness=k, t_release=1.0, t_end=float(t[-1])
    )
    (held,) = [w for w in r.warnings if w.startswith("linear_damping sits at its bound")]
    assert "energy put in" in held
    texts = [*r.warnings, *(str(s["reason"]) for s in r.to_json()["evidence"]["steps"])]
    for word in ("reverse", "tow", "seed 0", "a body cannot have"):
        assert not any(word in text for text in texts), word
