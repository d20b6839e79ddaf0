"""The thrust calibration report from a synthetic calibration table: a readable figure with
units on its axes, and report.md with the summary (units per parameter) first, figure linked."""

from __future__ import annotations

import re

import numpy as np
import pytest
from PIL import Image

from estimation.figures import DPI
from estimation.thrust.calibration_report import write_calibration_report
from estimation.thrust.curve import fit_thrust_curve


@pytest.fixture
def calibration() -> dict:
    """Two thrusters, a sweep out and back on both sides of a known power-law curve."""
    rng = np.random.default_rng(7)
    commands = [0.0, 0.2, 0.4, 0.6, 0.8, 0.6, 0.4, 0.2, 0.0, -0.2, -0.4, -0.6, -0.8, -0.4, 0.0]
    table, previous = [], 0.0
    for i, u in enumerate(commands):
        sign = (u > previous) - (u < previous)
        previous = u
        abs_sign = sign * (1 if u > 0 else -1 if u < 0 else 0)
        ue = u - 0.01 * sign
        f = 30 * max(ue - 0.05, 0) ** 0.8 - 22 * max(-ue - 0.06, 0) ** 0.85
        thrust = f + rng.normal(0, 0.05)
        table.append({
            "step": i, "command": u, "sweep_sign": sign,
            "direction": {1: "up", -1: "down", 0: "hold"}[abs_sign],
            "thrust_n": 2 * thrust, "thrust_std_n": 0.2, "thrust_per_thruster_n": thrust,
            "supply_voltage_v": 15.8 - 0.5 * abs(u), "samples": 5,
        })  # fmt: skip
    fit = fit_thrust_curve(
        [r["command"] for r in table],
        [r["thrust_per_thruster_n"] for r in table],
        [float(r["sweep_sign"]) for r in table],
    )
    return {"run_id": "0123456789abcdef", "thrusters": 2, "table": table, "fit": fit.to_json()}


def test_calibration_report_has_a_readable_figure_and_a_summary_with_units(calibration, tmp_path):
    paths = write_calibration_report(calibration, tmp_path / "report")
    assert sorted(p.name for p in paths) == ["calibration.png", "calibration.svg", "report.md"]
    assert all(p.is_file() and p.stat().st_size > 0 for p in paths)
    with Image.open(tmp_path / "report" / "calibration.png") as img:
        assert img.width >= 1000  # a readable figure, not a thumbnail
        assert img.info["dpi"][0] == pytest.approx(DPI, abs=0.5)
    svg = (tmp_path / "report" / "calibration.svg").read_text(encoding="utf-8")
    assert "command [fraction of full scale]" in svg
    assert "thrust per thruster [N]" in svg and "residual [N]" in svg
    assert "inverse map" in svg and "|command| falling" in svg

    md = (tmp_path / "report" / "report.md").read_text(encoding="utf-8")
    summary = md.split("## Summary", 1)[1].split("## Figures", 1)[0]
    params = calibration["fit"]["parameters"]
    gain = params["forward_gain"]
    assert f"| forward_gain | {gain['value']:.5g} ± {gain['std']:.2g} | N |" in summary
    assert "| forward_exponent |" in summary and "1 (dimensionless)" in summary
    assert re.search(r"\| hysteresis \| [-0-9.e]+ ± [0-9.e-]+ \| command \(fraction", summary)
    assert f"| RMSE of the fit | {calibration['fit']['rmse_n']:.3g} | N |" in summary
    volts = [r["supply_voltage_v"] for r in calibration["table"]]
    assert (
        f"| supply voltage, mean | {np.mean(volts):.2f} (range {min(volts):.2f} … "
        f"{max(volts):.2f}) | V |"
    ) in summary
    dead = (
        f"{-params['reverse_dead_band']['value']:.3g} … {params['forward_dead_band']['value']:.3g}"
    )
    assert f"| dead band | {dead} |" in summary
    assert md.index("## Summary") < md.index("## Figures") < md.index("## Measured steps")
    assert set(re.findall(r"\]\(([^)]+)\)", md)) == {"calibration.png", "calibration.svg"}


def test_a_calibration_without_a_table_is_refused(tmp_path):
    with pytest.raises(ValueError, match="calibration: got no table"):
        write_calibration_report({"run_id": "x", "table": []}, tmp_path)


def test_a_calibration_with_telemetry_adds_the_stand_figure_and_columns(calibration, tmp_path):
    """Steps carrying the controller's RPM and current (and so power and efficiency) get
    the thrust-stand figure and their columns in the measured table."""
    for row in calibration["table"]:
        f, volts = row["thrust_per_thruster_n"], row["supply_voltage_v"]
        amps = 12.0 * (abs(f) / 30.0) ** 1.5
        row |= {"current_a": amps, "rpm": 3500 * np.sign(f) * np.sqrt(abs(f) / 30.0)}
        if amps > 0:
            row |= {"power_w": volts * amps, "efficiency_n_per_w": abs(f) / (volts * amps)}
    paths = write_calibration_report(calibration, tmp_path / "report")
    assert {"stand.png", "stand.svg"} <= {p.name for p in paths}
    svg = (tmp_path / "report" / "stand.svg").read_text(encoding="utf-8")
    assert "motor current per thruster [A]" in svg and "efficiency |F|/(V·I) [N/W]" in svg
    md = (tmp_path / "report" / "report.md").read_text(encoding="utf-8")
    assert "| current [A] | RPM | efficiency [N/W] |" in md
    full = max(calibration["table"], key=lambda r: r["command"])
    assert (
        f"| {full['current_a']:.2f} | {full['rpm']:.0f} | {full['efficiency_n_per_w']:.3f} |" in md
    )
