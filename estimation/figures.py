"""The look every report figure shares: readable size, PNG at 150 dpi beside an SVG with real
text, short run labels instead of UUIDs, and the Markdown that links the figures.

matplotlib's object API only (``Figure`` + canvas), so no pyplot state is shared between
threads; the SVG is written with ``svg.fonttype = none`` so its labels stay searchable text.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: Raster resolution of the PNGs (a 12 in wide figure is 1800 px).
DPI = 150
#: Width of a full-page report figure, inches.
WIDTH_IN = 12.0
#: Width of a figure with three panels per row, inches (1950 px).
WIDE_IN = 13.0
#: Colours: measurements, model before the effect search, model after it.
MEASURED, BEFORE, AFTER = "0.25", "tab:orange", "tab:blue"
#: Time axis label of every time series in a report.
TIME_LABEL = "time from release [s]"


#: Fixed margins, inches (a layout engine costs a full extra draw per file written).
LEFT_IN, RIGHT_IN, TOP_IN, BOTTOM_IN = 0.85, 0.25, 0.75, 0.6


def new_figure(height_in: float, width_in: float = WIDTH_IN) -> Figure:
    """A blank figure of ``width_in`` × ``height_in`` inches with fixed margins."""
    fig = Figure(figsize=(width_in, height_in))
    fig.subplots_adjust(
        left=LEFT_IN / width_in,
        right=1 - RIGHT_IN / width_in,
        top=1 - TOP_IN / height_in,
        bottom=BOTTOM_IN / height_in,
    )
    return fig


def save_figure(fig: Figure, folder: Path, stem: str) -> list[Path]:
    """Write ``stem.png`` (150 dpi) and ``stem.svg`` into folder; returns both paths."""
    FigureCanvasAgg(fig)
    png, svg = folder / f"{stem}.png", folder / f"{stem}.svg"
    fig.savefig(png, dpi=DPI)
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": stem}):
        fig.savefig(svg, format="svg", metadata={"Date": None})
    return [png, svg]


def prefixed(values: Sequence[np.ndarray], unit: str) -> tuple[float, str]:
    """A scale and prefixed unit (m → mm, µm) that shows ``values`` with 1–3 integer digits,
    so small residuals get readable ticks instead of an offset like ``1e−5`` on the axis."""
    peak = max((float(np.max(np.abs(v))) for v in values if np.size(v)), default=0.0)
    if peak == 0.0 or peak >= 0.1:
        return 1.0, unit
    if peak >= 1e-4:
        return 1e-3, "m" + unit
    return 1e-6, "µ" + unit


def run_label(index: int, run_id: str, detail: str = "") -> str:
    """``run 1 (a1b2c3d4), +15 N``: the order in the report, the id prefix, what drove it."""
    label = f"run {index} ({run_id[:8]})"
    return f"{label}, {detail}" if detail else label


def signed(value: float, unit: str) -> str:
    """A drive with its sign and unit, 3 significant digits: ``+15 N``, ``-0.907 N·m``."""
    return f"{value:+.3g} {unit}"


def figure_links(figures: Sequence[tuple[str, Path]]) -> list[str]:
    """Markdown for the figures: a heading, then per figure its caption, the PNG shown
    inline and a link to the SVG beside it (paths relative to report.md)."""
    lines = ["## Figures", ""]
    for caption, png in figures:
        lines += [
            f"**{caption}** ([SVG]({png.with_suffix('.svg').name}))",
            "",
            f"![{caption}]({png.name})",
            "",
        ]
    return lines


def effects_text(effects: Sequence[str]) -> str:
    """What a model is, for titles: "base model" or "base model + coulomb_friction"."""
    return "base model + " + ", ".join(effects) if effects else "base model"


@dataclass(frozen=True)
class FitRow:
    """One run of a fit figure: time from release, measured values, and the residuals of
    the model before and after the effect search."""

    label: str
    t: np.ndarray
    measured: np.ndarray
    residual_before: np.ndarray
    residual_after: np.ndarray

    def __post_init__(self) -> None:
        sizes = {
            name: np.size(getattr(self, name))
            for name in ("t", "measured", "residual_before", "residual_after")
        }
        if len(set(sizes.values())) > 1:
            shown = ", ".join(f"{name} {size}" for name, size in sizes.items())
            raise ValueError(f"{self.label}: one value per sample needed; got {shown}")


def fit_over_measurements(
    rows: Sequence[FitRow],
    quantity: str,
    unit: str,
    title: str,
    legend_loc: Literal["best", "upper right"] = "best",
) -> Figure:
    """One row per run: measured vs model before and after against time from release, then
    the residual before and the residual after, each on its own scale with its unit."""
    fig = new_figure(2.7 * len(rows) + 1.0, WIDE_IN)
    grid = fig.add_gridspec(len(rows), 3, width_ratios=(2.2, 1.4, 1.4), hspace=0.45, wspace=0.28)
    for i, row in enumerate(rows):
        ax = fig.add_subplot(grid[i, 0])
        before, after = row.measured - row.residual_before, row.measured - row.residual_after
        ax.plot(row.t, before, "--", lw=1.4, color=BEFORE, label="model before")
        ax.plot(row.t, after, "-", lw=1.4, color=AFTER, label="model after")
        ax.plot(row.t, row.measured, ".", ms=2.5, color=MEASURED, label="measured", zorder=3)
        ax.set_title(row.label, loc="left", fontsize=10)
        ax.set_ylabel(f"{quantity} [{unit}]")
        axes = [ax]
        residuals = (("before", row.residual_before, BEFORE), ("after", row.residual_after, AFTER))
        for col, (which, residual, colour) in enumerate(residuals, start=1):
            scale, shown = prefixed([residual], unit)
            ax_res = fig.add_subplot(grid[i, col], sharex=ax)
            ax_res.axhline(0.0, color="0.6", lw=0.8)
            ax_res.plot(row.t, residual / scale, ".", ms=2.5, color=colour)
            ax_res.set_title(f"measured − model {which}", loc="left", fontsize=10)
            ax_res.set_ylabel(f"residual [{shown}]")
            axes.append(ax_res)
        if i == 0:
            ax.legend(loc=legend_loc, fontsize=8)
        if i == len(rows) - 1:
            for a in axes:
                a.set_xlabel(TIME_LABEL)
    fig.suptitle(title, fontsize=11)
    return fig
