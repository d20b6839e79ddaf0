"""The Type A rows of an uncertainty budget (evaluated from the data).

The random error of a coefficient has up to four estimates, and only the largest enters u_c
(the others are listed, marked "not combined"): they estimate the same error, so adding
them would count it two or three times, and taking the largest keeps a σ never smaller than
the data support.

* the fit's white σ, σ̂²(JᵀJ)⁻¹: the noise of the samples. Not the estimate's σ with the
  residual's within-run correlation (``estimation.stats.serial``): a structured residual
  here is mostly what the declared Type B sources do to the runs, and counting it in the
  fit's σ too counts them twice — on the 12 kg chain of
  tests/estimation/uncertainty/test_uncertainty_chain.py U of the inertia became 0.22 kg against
  0.13 kg from a Monte Carlo of the whole chain;
* the encoder's quantization (``estimation.stats.quantization``): the same sample error
  (its variance is Q²/12 plus the residual's excess noise) with the correlation that one
  unknown phase per run puts into it, which the residual cannot show. It comes from the
  encoder step and the fitted motion, not from the residual, so no Type B source is in
  it; it is the fit's σ where it is the larger (slow motion, little noise to dither the
  encoder: the 143 kg tows of tests/estimation/term_search/test_term_coverage.py);
* the run-level bootstrap;
* the repeatability of repeat campaigns (``estimation.uncertainty.repeats``).

The release-timing refit and the thrust calibration draws
(``estimation.axis.drive_uncertainty``) are separate random sources and enter as they are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace

from estimation.axis.tow_estimate import well_determined
from estimation.axis.tow_section import TowResult
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.terms import LIBRARY
from estimation.uncertainty.rows import BudgetRow, counted_once, repeatability_row

QUANTIZATION = "encoder quantization (step Q, one unknown phase per run)"
FIT_ROW = "fit (σ̂²(JᵀJ)⁻¹)"
COMBINATION_ROW = "fit (delta method: the coefficients' σ̂²(JᵀJ)⁻¹ or quantization σ)"
NOT_IDENTIFIED = "not identified by these runs: no σ, so no U"


def coefficient_unit(name: str, axis: str) -> str:
    """The SI unit of a fitted coefficient or effect on ``axis``."""
    if name == "inertia":
        return "kg" if axis == "surge" else "kg·m²"
    return LIBRARY[name].unit(axis) if name in LIBRARY else ""


def combination_rows(
    result: TowResult,
    fit: MotionFit,
    conditions: tuple[Mapping[str, float], Sequence[float]],
    dof_fit: float,
) -> dict[str, BudgetRow]:
    """The Type A row of each well-determined combination (a tow's terminal speed, its drag
    at a tested speed), by name: its delta-method σ (``motion.well_determined``) through the
    fit's correlation and, as for the coefficients, the larger of the white σ and the
    encoder quantization's σ (the serial-correlation σ would count the declared Type B
    sources twice, module doc). The bootstrap, release-timing and calibration draws are
    kept per raw coefficient only, so they are not in it (docs/uncertainty.md)."""
    forms = [f for f in (fit.std_white, fit.std_quantization) if f is not None] or [fit.std]
    sigmas: dict[str, list[float]] = {}
    for std in forms:
        for c in well_determined(replace(fit, std=std), *conditions, result.axis):
            if c.std is not None:
                sigmas.setdefault(c.name, []).append(c.std)
    out = {}
    for c in result.well_determined:
        found = [s for s in sigmas.get(c.name, []) if math.isfinite(s)]
        if c.std is None or not math.isfinite(c.std) or not found:
            out[c.name] = BudgetRow(
                COMBINATION_ROW, "A", c.unit, math.nan, 1.0, math.nan, dof_fit, note=NOT_IDENTIFIED
            )
        else:
            u = max(found)
            out[c.name] = BudgetRow(COMBINATION_ROW, "A", c.unit, u, 1.0, u, dof_fit)
    return out


def type_a_rows(
    result: TowResult, fit: MotionFit, repeat_std: Mapping[str, tuple[float, int]]
) -> dict[str, list[BudgetRow]]:
    rows: dict[str, list[BudgetRow]] = {}
    dof_fit = max(fit.n_samples - fit.n_params, 1)
    boot = result.bootstrap
    drive = result.section.uncertainty
    for i, name in enumerate(fit.names):
        unit = coefficient_unit(name, result.axis)
        if not math.isfinite(float(fit.std[i])):  # the data do not determine it: no U at all
            rows[name] = [
                BudgetRow(FIT_ROW, "A", unit, math.nan, 1.0, math.nan, dof_fit, note=NOT_IDENTIFIED)
            ]
            continue
        noise = fit.std if fit.std_white is None else fit.std_white
        random = [BudgetRow(FIT_ROW, "A", unit, float(noise[i]), 1.0, 0.0, dof_fit)]
        if fit.std_quantization is not None:
            random.append(
                BudgetRow(QUANTIZATION, "A", unit, float(fit.std_quantization[i]), 1, 0, dof_fit)
            )
        if boot is not None and boot.used > 1 and math.isfinite(boot.std.get(name, math.nan)):
            random.append(
                BudgetRow(
                    f"bootstrap over runs ({boot.used} resamples)",
                    "A",
                    unit,
                    boot.std[name],
                    1.0,
                    0.0,
                    max(len(result.runs) - 1, 1),
                )
            )
        if name in repeat_std:
            s, n = repeat_std[name]
            random.append(repeatability_row(unit, s, n))
        out = counted_once(random)
        if drive is not None and drive.std_release_timing.get(name, 0.0) > 0:
            u = drive.std_release_timing[name]
            out.append(
                BudgetRow(
                    "release timing (refit with each release moved by its σ_t)",
                    "A",
                    unit,
                    u,
                    1.0,
                    u,
                    math.inf,
                    note="σ_t from the release write's bracket and the clock",
                )
            )
        if drive is not None and drive.draws > 1 and drive.std_calibration.get(name, 0.0) > 0:
            u = drive.std_calibration[name]
            out.append(
                BudgetRow(
                    f"thrust calibration ({drive.draws} curve draws)",
                    "A",
                    unit,
                    u,
                    1.0,
                    u,
                    drive.draws - 1,
                    note="the calibration fit's covariance",
                )
            )
        rows[name] = out
    return rows
