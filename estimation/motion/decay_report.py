"""Free-decay report: result.json, report.md (the one report, ``fit_report.report_markdown``,
with each record's fitted window) and one figure per fitted record: measured x
and the fitted model against time from release, with the residual beneath
(docs/estimation.md, *Free decay*)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from estimation.figures import new_figure, run_label, save_figure
from estimation.fit_report import report_markdown, write_result_and_markdown
from estimation.motion.decay_section import DecayResult
from estimation.motion.records import Record
from estimation.motion.terms import DOFS, units_of

#: x's unit per DOF.
POSITION_UNIT = {dof: units_of(dof)["position"] for dof in DOFS}


def fitted_window(
    result: DecayResult, record: Record, t_end: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The samples the fit used (``t`` from release, s; measured x) and the model there:
    x_model = x − residual (``x_eq + ξ``, estimation.motion.output_error_fit). ``t_end``: the
    window's end (default: the one the result used)."""
    if result.fit_after is None:
        raise ValueError("result: got a result without its fit, allowed: one made by estimate")
    index = result.runs.index(record.run_id)
    release = result.section.release_time_s[record.run_id]
    if t_end is None and record.run_id in result.section.window:
        t_end = result.section.window[record.run_id].end
    t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
    keep = (t >= release) & (t <= (np.inf if t_end is None else t_end))
    residual = result.fit_after.residuals[index]
    if int(keep.sum()) != residual.size:
        raise ValueError(
            f"record {record.run_id}: got {int(keep.sum())} samples in the window, allowed: "
            f"the {residual.size} the fit used"
        )
    return t[keep] - release, x[keep], x[keep] - residual


def _figure(result: DecayResult, records: Sequence[Record], ends: Mapping[str, float | None]):
    unit = POSITION_UNIT.get(result.axis, "m or rad")
    fig = new_figure(3.6 * len(records))
    axes = fig.subplots(2 * len(records), 1, sharex=False, height_ratios=[3, 1] * len(records))
    fig.subplots_adjust(hspace=0.6)
    for i, record in enumerate(records):
        t, x, model = fitted_window(result, record, ends.get(record.run_id))
        top, bottom = axes[2 * i], axes[2 * i + 1]
        top.plot(t, x, ".", ms=2, color="0.4", label="measured")
        top.plot(t, model, "-", lw=1.2, color="C0", label="model")
        top.set_ylabel(f"{result.axis} ({unit})")
        top.set_title(run_label(i + 1, record.run_id), fontsize=9, loc="left")  # as the page
        top.legend(loc="upper right", fontsize=8)
        bottom.plot(t, x - model, "-", lw=0.8, color="C3")
        bottom.axhline(0.0, color="0.6", lw=0.6)
        bottom.set_ylabel(f"residual ({unit})")
        bottom.set_xlabel("time from release (s)")
    return fig


def _markdown(
    result: DecayResult,
    figures: Sequence[tuple[str, Path]],
    budget: Mapping[str, Any] | None = None,
) -> str:
    """The one report (``fit_report.report_markdown``); the decay's own section: each
    record's fitted window and what ended it."""
    windows = [
        f"- {run}: {result.section.release_time_s[run]:.4g} s to {w.end:.4g} s ({w.ended_by})"
        for run, w in result.section.window.items()
    ]
    return report_markdown(
        result,
        f"Free decay of {result.axis}: {', '.join(result.runs)}",
        {rid: run_label(i, rid) for i, rid in enumerate(result.runs, start=1)},
        figures,
        ["", "## Fitted windows", "", *windows] if windows else [],
        budget=budget,
    )


def write_decay_report(
    result: DecayResult,
    records: Sequence[Record],
    directory: str | Path,
    ends: Mapping[str, float | None] | None = None,
    budget: Mapping[str, Any] | None = None,
) -> list[Path]:
    """Write result.json, report.md and the ``decay`` figure (PNG and SVG) into directory;
    ``ends``: each record's end of free motion (s, as given to the fit); ``budget``: the
    result's uncertainty budget document, shown in report.md. The paths written."""
    if tuple(r.run_id for r in records) != result.runs:
        raise ValueError(
            f"records: got {[r.run_id for r in records]}, allowed: the result's runs "
            f"{list(result.runs)} in the same order"
        )
    out = Path(directory)
    out.mkdir(parents=True, exist_ok=True)
    fig = save_figure(_figure(result, records, ends or {}), out, "decay")
    figures = [("Measured and fitted free decay, and the residual, per record", fig[0])]
    written = write_result_and_markdown(out, result, _markdown(result, figures, budget), budget)
    return [*written, *fig]
