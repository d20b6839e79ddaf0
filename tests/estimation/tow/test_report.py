"""Report files: JSON with the documented schema, Markdown with the summary first and every
figure linked, figures at readable size with unit labels and time from release."""

import json
import re
import uuid
from dataclasses import replace

import numpy as np
import pytest
from PIL import Image

from estimation import estimate
from estimation.axis import tow_report
from estimation.axis.prepared_run import prepare
from estimation.axis.tow_report import fit_figure, force_figure, run_labels, write_report
from estimation.data.csv_import import run_from_csv
from estimation.data.left_out import LeftOut
from estimation.figures import DPI, TIME_LABEL, FitRow
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
#: Recorded runs carry service/PLC time: release ~88 s after the clock started.
CLOCK_OFFSET_S = 88.0


def _late_clock(runs):
    """The runs with UUID ids and their times shifted as a service clock would have them."""
    return [
        replace(
            r,
            run_id=str(uuid.UUID(int=i + 1)),
            t=r.t + CLOCK_OFFSET_S,
            t_release=r.t_release + CLOCK_OFFSET_S,
            t_end=None if r.t_end is None else r.t_end + CLOCK_OFFSET_S,
        )
        for i, r in enumerate(runs)
    ]


@pytest.fixture(scope="module")
def surge():
    runs = _late_clock(tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=21))
    return runs, estimate(runs, n_bootstrap=5)


def test_report_writes_json_markdown_and_figures(surge, tmp_path):
    runs, result = surge
    paths = write_report(result, runs, tmp_path / "out")
    names = sorted(p.name for p in paths)
    assert names == [
        "fit.png", "fit.svg", "force_residual.png", "force_residual.svg", "report.md",
        "result.json",
    ]  # fmt: skip
    for p in paths:
        if p.suffix == ".png":
            assert p.read_bytes()[:8] == PNG_MAGIC
            with Image.open(p) as img:
                assert img.width >= 1500  # readable, not a thumbnail
                assert img.info["dpi"][0] == pytest.approx(DPI, abs=0.5)
    doc = json.loads((tmp_path / "out" / "result.json").read_text())
    for key in ("axis", "method", "coefficients", "effects", "ambiguous", "rmse_before",
                "rmse_after", "runs"):  # fmt: skip
        assert key in doc
    for key in ("inertia", "linear_damping", "quadratic_damping"):
        assert set(doc["coefficients"][key]) == {"value", "std", "unit"}
    assert doc["effects"][0]["name"] == "coulomb_friction" and doc["effects"][0]["unit"] == "N"
    md = (tmp_path / "out" / "report.md").read_text(encoding="utf-8")
    assert "coulomb_friction" in md and "| **all** |" in md and "ambiguous" in md
    # the summary comes first: coefficients ± σ with units, effects, RMSE, warnings
    summary = md.split("## Summary", 1)[1].split("## Figures", 1)[0]
    assert "| inertia | 143." in summary and "| kg |" in summary
    assert "effect `coulomb_friction`" in summary and "RMSE before → after" in summary
    assert "warnings" in summary
    # every figure written is linked from report.md: PNG inline, SVG beside it
    linked = set(re.findall(r"\]\(([^)]+)\)", md))
    assert {p.name for p in paths if p.suffix in (".png", ".svg")} == linked
    assert md.index("## Summary") < md.index("## Figures") < md.index("## Evidence")


def test_fit_figure_runs_from_release_with_units_and_short_labels(surge):
    runs, result = surge
    prepared = [prepare(r) for r in runs]
    labels = run_labels(prepared, "surge")
    fig = fit_figure(result, prepared, labels)
    rows = [fig.axes[i : i + 3] for i in range(0, len(fig.axes), 3)]
    assert len(rows) == len(runs)
    for (ax, res_before, res_after), run in zip(rows, runs, strict=True):
        assert ax.get_ylabel() == "position [m]"
        assert re.fullmatch(r"residual \[(m|mm|µm)\]", res_before.get_ylabel())
        assert re.fullmatch(r"residual \[(m|mm|µm)\]", res_after.get_ylabel())
        title = ax.get_title(loc="left")
        assert title.startswith("run ") and run.run_id[:8] in title and run.run_id not in title
        assert title.endswith(" N")  # the weight's force
        for line in ax.get_lines():
            t = line.get_xdata()
            assert 0.0 < t[0] <= 0.25  # first sample after release, not ~88 s of clock
    assert rows[0][0].get_title(loc="left") == "run 1 (00000000), +4.9 N"
    assert [a.get_xlabel() for a in rows[-1]] == [TIME_LABEL] * 3
    assert {line.get_label() for line in rows[0][0].get_lines()} == {
        "measured", "model before", "model after"
    }  # fmt: skip


def test_force_figure_plots_force_residual_against_velocity(surge):
    runs, result = surge
    prepared = [prepare(r) for r in runs]
    fig = force_figure(result, prepared, run_labels(prepared, "surge"))
    before, after = fig.axes
    for ax in (before, after):
        assert ax.get_xlabel() == "model velocity [m/s]"
        assert re.fullmatch(r"force residual \[(N|mN|µN)\]", ax.get_ylabel())
        assert len([line for line in ax.get_lines() if line.get_label().startswith("run ")]) == 4
    assert "coulomb_friction" in after.get_title(loc="left")


def test_yaw_report_labels_angle_and_torque(tmp_path):
    runs = _late_clock(tow_set(axis="yaw", seed=5))
    result = estimate(runs, n_bootstrap=0, search_effects=False)
    paths = write_report(result, runs, tmp_path)
    svg = {p.stem: p.read_text(encoding="utf-8") for p in paths if p.suffix == ".svg"}
    for text in ("angle [rad]", TIME_LABEL, "measured − model before", "N·m"):
        assert text in svg["fit"] or text in svg["force_residual"]
    assert "model yaw rate [rad/s]" in svg["force_residual"]
    assert "torque residual [" in svg["force_residual"]
    assert "run 1 (00000000), +0.454 N·m" in svg["fit"]


def test_report_refuses_other_runs(tmp_path):
    runs = tow_set(seed=22)
    result = estimate(runs, n_bootstrap=0, search_effects=False)
    with pytest.raises(ValueError, match="runs: got"):
        write_report(result, runs[:2], tmp_path)


def test_report_for_seed_method(tmp_path):
    runs = tow_set(seed=23)
    result = estimate(runs, method="ls-steady")
    paths = write_report(result, runs, tmp_path)
    assert len(paths) == 6


def _numpy_tow(path, noise_m: float) -> None:
    """A tow written by another tool: ``t, position`` at 10 Hz, 1 s still, then 24.5 N
    (Euler at 1 kHz, 150 kg, K_L 10, K_Q 20)."""
    dt, force, inertia, k_l, k_q = 0.001, 24.5, 150.0, 10.0, 20.0
    t = np.arange(0.0, 16.0 + dt / 2, dt)
    x, v, p = np.zeros_like(t), 0.0, 0.0
    for i, ti in enumerate(t):
        x[i] = p
        if ti >= 1.0:
            v += (force - k_l * v - k_q * abs(v) * v) / inertia * dt
            p += v * dt
    rows = np.arange(0, t.size, 100)
    noisy = x[rows] + np.random.default_rng(0).normal(0.0, noise_m, rows.size)
    np.savetxt(path, np.column_stack([t[rows], noisy]), delimiter=",", header="t,position",
               comments="")  # fmt: skip


@pytest.mark.parametrize("noise_m", [1e-5, 1e-4])
def test_report_draws_a_release_found_from_motion_and_refined_across_a_sample(tmp_path, noise_m):
    """The fit refines a release found from the motion onset; when the refined instant falls
    before a sample the found one was after, the fit has one more sample than the found
    window: the report must draw the samples the fit used (it failed with "operands could
    not be broadcast together with shapes (151,) (150,)")."""
    _numpy_tow(tmp_path / "tow.csv", noise_m)
    run = run_from_csv(tmp_path / "tow.csv", axis="surge", drive=24.5)
    result = estimate([run], n_bootstrap=0, search_effects=False)
    refined = result.section.windows[run.run_id]
    assert refined.release_source == "motion onset, refined by the fit"
    found_samples = np.count_nonzero(run.t > run.t_release)
    assert np.count_nonzero(run.t > refined.t_release) == found_samples + 1  # the case itself
    paths = write_report(result, [run], tmp_path / "report")
    assert {p.name for p in paths} >= {"fit.png", "force_residual.png", "report.md"}


def test_a_fit_row_with_mismatched_samples_names_them():
    with pytest.raises(ValueError, match="run 1: one value per sample needed; got t 3, "):
        FitRow("run 1", np.zeros(3), np.zeros(3), np.zeros(2), np.zeros(3))


def test_the_report_lists_the_samples_a_fit_left_out(surge, tmp_path, monkeypatch):
    runs, result = surge
    # report.md and result.json are read here, the figures never (their files are
    # test_report_writes_json_markdown_and_figures's): built, not rendered to PNG and SVG
    monkeypatch.setattr(
        tow_report, "save_figure", lambda fig, out, stem: [out / f"{stem}.png", out / f"{stem}.svg"]
    )
    first = result.runs[0]
    hole = LeftOut(12.3, 12.7, 4, "PLC read failed", in_motion=True)
    windows = result.section.windows
    windows = dict(windows) | {first: replace(windows[first], left_out=(hole,))}
    section = replace(result.section, windows=windows)
    write_report(replace(result, section=section), runs, tmp_path / "out")
    md = (tmp_path / "out" / "report.md").read_text()
    assert "## Samples left out" in md
    assert f"({first[:8]}), " in md.split("## Samples left out")[1].splitlines()[2]
    assert (
        md.split("## Samples left out")[1]
        .splitlines()[2]
        .endswith(": 4 samples left out at 12.3–12.7 s (PLC read failed)")
    )
    doc = json.loads((tmp_path / "out" / "result.json").read_text())
    assert doc["windows"][first]["left_out"] == [hole.to_json()]


def test_the_evidence_reads_a_quantized_residual_as_the_misfit_rule_does():
    """Clean 143 kg tows on a 0.1 mm encoder grid (``tests.estimation.term_cases``): the
    residual of a quantized encoder is never white (Ljung–Box p far below 10⁻³) yet lacks no
    force; the evidence line says so beside the Q instead of leaving a p of 1e-60 to alarm
    its reader. A tow set with an undeclared dry friction fitted without the search says
    its coefficients may be biased."""
    from estimation.fit_report import evidence_section
    from tests.estimation.term_cases import tow_set as grid_tows

    clean = estimate(grid_tows("143kg", seed=300), n_bootstrap=0)
    assert clean.whiteness_after is not None and clean.whiteness_after.p_value < 1e-3
    (line,) = [x for x in evidence_section(clean, "m") if x.startswith("BIC")]
    assert "not white (p < 0.001) but within 3× its noise floor" in line
    runs = grid_tows("143kg", seed=300, reverse=True, coulomb=0.05 * 44.1)
    biased = estimate(runs, search_effects=False, n_bootstrap=0)
    assert biased.possibly_biased
    (line,) = [x for x in evidence_section(biased, "m") if x.startswith("BIC")]
    assert "the coefficients may be biased by it" in line
