"""Thrust calibration report: report.md (summary table first, figures linked) and the figure
``calibration``: thrust per thruster vs command with error bars by sweep direction, the fitted
curve and points of its inverse map, over a residual panel; when the steps carry the
controller's telemetry, the figure ``stand``: thrust vs motor current and efficiency (N/W) vs
thrust, as a thrust stand reports them."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from estimation.figures import MEASURED, figure_links, new_figure, save_figure
from estimation.thrust.curve import PARAMS, ThrustCurve

#: Axis labels (units in brackets, as in every report figure).
COMMAND_LABEL = "command [fraction of full scale]"
THRUST_LABEL = "thrust per thruster [N]"
#: Marker and colour per sweep direction of the table ("up" = |command| rising).
DIRECTIONS = {
    "up": ("^", "tab:blue", "|command| rising"),
    "down": ("v", "tab:red", "|command| falling"),
    "hold": ("o", MEASURED, "held"),
}
#: Forces (as fractions of each side's reach) where the inverse map is drawn.
INVERSE_FRACTIONS = (0.2, 0.4, 0.6, 0.8, 1.0)
#: What a parameter's unit means, for the summary table.
UNIT_TEXT = {"command": "command (fraction of full scale)", "1": "1 (dimensionless)"}


def _points(calibration: dict[str, Any]) -> dict[str, np.ndarray]:
    """The table as arrays: command, thrust and its σ per thruster, direction, supply."""
    table = calibration["table"]
    n = max(int(calibration.get("thrusters") or 1), 1)
    return {
        "command": np.array([r["command"] for r in table], dtype=float),
        "thrust": np.array([r["thrust_per_thruster_n"] for r in table], dtype=float),
        "std": np.array([(r.get("thrust_std_n") or 0.0) / n for r in table], dtype=float),
        "direction": np.array([r.get("direction", "hold") for r in table]),
        "sign": np.array([float(r.get("sweep_sign", 0.0)) for r in table]),
        "volts": np.array([r.get("supply_voltage_v", np.nan) for r in table], dtype=float),
    }


def inverse_points(curve: ThrustCurve) -> tuple[np.ndarray, np.ndarray]:
    """(commands, forces): the inverse map at fractions of the reach on each side."""
    reach = (float(curve.force(curve.command_min)), float(curve.force(curve.command_max)))
    forces = np.array(
        [f * reach[0] for f in INVERSE_FRACTIONS if reach[0] < 0]
        + [f * reach[1] for f in INVERSE_FRACTIONS if reach[1] > 0]
    )
    return np.asarray(curve.command_for_force(forces), dtype=float), forces


def calibration_figure(calibration: dict[str, Any]) -> Figure:
    """Thrust vs command (measured ± σ by direction, fitted curve, inverse map) above the
    residual (measured − fit) vs command."""
    curve = ThrustCurve.from_json(calibration["fit"])
    pts = _points(calibration)
    fig = new_figure(7.5)
    grid = fig.add_gridspec(2, 1, height_ratios=(2.6, 1.0), hspace=0.12)
    ax = fig.add_subplot(grid[0])
    ax_res = fig.add_subplot(grid[1], sharex=ax)
    u = np.linspace(curve.command_min, curve.command_max, 400)
    ax.plot(
        u,
        curve.force(u),
        "-",
        lw=1.5,
        color="tab:green",
        label="fitted curve (mid-hysteresis)",
        zorder=2,
    )
    inv_u, inv_f = inverse_points(curve)
    ax.plot(inv_u, inv_f, "x", ms=8, mew=1.8, color="black", label="inverse map", zorder=4)
    residual = pts["thrust"] - curve.force(pts["command"], pts["sign"])
    for direction, (marker, colour, label) in DIRECTIONS.items():
        sel = pts["direction"] == direction
        if not np.any(sel):
            continue
        style: dict[str, Any] = {"fmt": marker, "ms": 5, "color": colour, "capsize": 3}
        u_sel, std_sel = pts["command"][sel], pts["std"][sel]
        ax.errorbar(u_sel, pts["thrust"][sel], yerr=std_sel, label=f"measured, {label}", **style)
        ax_res.errorbar(u_sel, residual[sel], yerr=std_sel, **style)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax_res.axhline(0.0, color="0.6", lw=0.8)
    ax.set_ylabel(THRUST_LABEL)
    ax.tick_params(labelbottom=False)
    ax.legend(loc="upper left", fontsize=8)
    ax_res.set_ylabel("residual [N]")
    ax_res.set_xlabel(COMMAND_LABEL)
    ax_res.set_title("measured − fit", loc="left", fontsize=10)
    fig.suptitle(
        f"thrust calibration, run {str(calibration.get('run_id', ''))[:8]}: "
        f"{calibration.get('thrusters', 1)} thrusters, RMSE {curve.rmse_n:.3g} N",
        fontsize=11,
    )
    return fig


def _has_stand(calibration: dict[str, Any]) -> bool:
    return any(r.get("current_a") is not None for r in calibration["table"])


def stand_figure(calibration: dict[str, Any]) -> Figure:
    """Thrust per thruster vs motor current (A), and efficiency |F|/P (N/W) vs thrust."""
    table = [r for r in calibration["table"] if r.get("current_a") is not None]
    thrust = np.array([r["thrust_per_thruster_n"] for r in table], dtype=float)
    amps = np.array([r["current_a"] for r in table], dtype=float)
    eff = np.array([r.get("efficiency_n_per_w", np.nan) for r in table], dtype=float)
    fig = new_figure(4.2)
    ax_i, ax_e = fig.subplots(1, 2)
    forward = thrust >= 0
    for sel, label, colour in ((forward, "forward", "tab:blue"), (~forward, "reverse", "tab:red")):
        ax_i.plot(amps[sel], thrust[sel], "o", ms=4, color=colour, label=label)
        ax_e.plot(np.abs(thrust[sel]), eff[sel], "o", ms=4, color=colour, label=label)
    ax_i.set_xlabel("motor current per thruster [A]")
    ax_i.set_ylabel(THRUST_LABEL)
    ax_i.axhline(0.0, color="0.6", lw=0.8)
    ax_i.legend(loc="best", fontsize=8)
    ax_e.set_xlabel("|thrust| per thruster [N]")
    ax_e.set_ylabel("efficiency |F|/(V·I) [N/W]")
    if not np.any(np.isfinite(eff)):
        ax_e.text(0.5, 0.5, "no supply voltage recorded", ha="center", transform=ax_e.transAxes)
    fig.suptitle("thrust stand: thrust vs current, efficiency vs thrust", fontsize=11)
    return fig


def response_figure(calibration: dict[str, Any]) -> Figure:
    """The largest step's load-cell reading against the first-order lag with the measured τ."""
    response = calibration["response"]
    step = response["largest_step"]
    fig = new_figure(4.0)
    ax = fig.subplots()
    ax.plot(step["t_s"], step["measured_n"], "o", ms=4, color=MEASURED, label="load cell")
    tau, std = response["time_constant_s"], response["std_s"]
    ax.plot(step["model_t_s"], step["model_n"], "-", color="tab:green",
            label=f"first-order lag, τ = {tau:.3g} ± {std:.1g} s")  # fmt: skip
    ax.axvline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time from the output change [s]")
    ax.set_ylabel("thrust, all thrusters [N]")
    ax.legend(loc="best", fontsize=8)
    fig.suptitle(
        f"step response: 90 % settling {response['settle_90_s']:.3g} s "
        f"({response['transients']} steps)",
        fontsize=11,
    )
    return fig


def _range(values: np.ndarray, fmt: str = ".2f") -> str:
    finite = values[np.isfinite(values)]
    if not finite.size:
        return "— (not recorded)"
    lo, mean, hi = finite.min(), finite.mean(), finite.max()
    return f"{mean:{fmt}} (range {lo:{fmt}} … {hi:{fmt}})"


def calibration_markdown(
    calibration: dict[str, Any], figures: Sequence[tuple[str, Path]] = ()
) -> str:
    """Summary table (fit parameters ± σ with units, RMSE, supply, dead bands), the figures,
    then the measured table."""
    fit = calibration["fit"]
    params = fit["parameters"]
    pts = _points(calibration)
    d_f, d_r = params["forward_dead_band"]["value"], params["reverse_dead_band"]["value"]
    lines = [
        f"# Thrust calibration report — run {calibration.get('run_id', '?')}",
        "",
        "## Summary",
        "",
        "| quantity | value ± σ | unit |",
        "|---|---|---|",
    ]
    for name in PARAMS:
        p = params[name]
        unit = UNIT_TEXT.get(p["unit"], p["unit"])
        lines.append(f"| {name} | {p['value']:.5g} ± {p['std']:.2g} | {unit} |")
    lo, hi = fit["command_range"]
    lines += [
        f"| dead band | {-d_r:.3g} … {d_f:.3g} | {UNIT_TEXT['command']} |",
        f"| RMSE of the fit | {fit['rmse_n']:.3g} | N |",
        f"| supply voltage, mean | {_range(pts['volts'])} | V |",
        _response_row(calibration.get("response")),
        f"| commands calibrated | {lo:g} … {hi:g} ({len(pts['command'])} steps) | "
        f"{UNIT_TEXT['command']} |",
        f"| thrusters on the load cell | {calibration.get('thrusters', 1)} | |",
        "",
        "Thrust is per thruster (load cell ÷ thrusters). Model: F = +k_f·(u_e − d_f)^p_f "
        "forward, −k_r·(−u_e − d_r)^p_r reverse, 0 inside the dead band, u_e = u − h·s/2 "
        "with s the sweep direction (hysteresis h).",
        "",
        *(figure_links(figures) if figures else []),
        "## Measured steps",
        "",
        "| step | command | direction | thrust/thruster [N] | σ [N] | supply [V] | "
        "current [A] | RPM | efficiency [N/W] | samples |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row, std in zip(calibration["table"], pts["std"], strict=True):
        lines.append(
            f"| {row.get('step', '')} | {row['command']:+.3f} | {row.get('direction', '')} | "
            f"{row['thrust_per_thruster_n']:+.3f} | {std:.3f} | "
            f"{_cell(row.get('supply_voltage_v'), '.2f')} | {_cell(row.get('current_a'), '.2f')} "
            f"| {_cell(row.get('rpm'), '.0f')} | {_cell(row.get('efficiency_n_per_w'), '.3f')} "
            f"| {row.get('samples', '')} |"
        )
    return "\n".join(lines) + "\n"


def _response_row(response: dict | None) -> str:
    if not response:
        return "| thrust lag τ | — (not measured) | s |"
    return (
        f"| thrust lag τ (90 % settling) | {response['time_constant_s']:.3g} ± "
        f"{response['std_s']:.1g} ({response['settle_90_s']:.3g}) | s |"
    )


def _cell(value: float | None, fmt: str) -> str:
    return "—" if value is None else f"{value:{fmt}}"


def write_calibration_report(calibration: dict[str, Any], folder: str | Path) -> list[Path]:
    """Write report.md and the figure ``calibration`` (150 dpi PNG and SVG) for a stored
    calibration (``{run_id, thrusters, table, fit}``) into folder; returns the paths."""
    if not calibration.get("table") or "fit" not in calibration:
        raise ValueError(
            "calibration: got no table or fit, allowed: a stored thrust calibration result"
        )
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    files = save_figure(calibration_figure(calibration), out, "calibration")
    figures = [("Thrust per thruster vs command, fitted curve, inverse map, residuals", files[0])]
    if _has_stand(calibration):
        stand = save_figure(stand_figure(calibration), out, "stand")
        figures.append(("Thrust vs motor current, efficiency vs thrust", stand[0]))
        files += stand
    if (calibration.get("response") or {}).get("largest_step"):
        step = save_figure(response_figure(calibration), out, "response")
        figures.append(("Step response and the measured thrust lag", step[0]))
        files += step
    md = out / "report.md"
    md.write_text(calibration_markdown(calibration, figures), encoding="utf-8")
    return [md, *files]
