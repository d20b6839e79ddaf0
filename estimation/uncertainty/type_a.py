"""The Type A rows of an uncertainty budget (evaluated from the data), one rule for every
kind of record.

The random error of a coefficient has up to four estimates, and only the largest enters u_c
(the others are listed, marked "not combined"): they estimate the same error, so adding
them would count it two or three times, and taking the largest keeps a σ never smaller than
the data support.

* the fit's σ. Where declared Type B inputs move the records themselves (a tow's hung
  masses, radii and encoder scale: ``DeclaredInput.moves_records``), the white σ̂²(JᵀJ)⁻¹
  with ν = n − p: a residual structured within a run is then mostly what those inputs do to
  the runs, and their re-fits propagate it; counting it in the fit's σ too counts them
  twice — on the 12 kg chain of tests/estimation/uncertainty/test_uncertainty_chain.py U of
  the inertia became 0.22 kg against 0.13 kg from a Monte Carlo of the whole chain.
  Everywhere else (no tolerance declared, or only constants the model is given, as a
  decay's stiffness) nothing else carries that structure: the estimate's own σ, the larger
  of the white and the serial-correlation σ (``estimation.stats.identify``), with
  ν = n_eff − p, n_eff the residual's effective sample size (``stats.misfit``: KVLCC2's
  roll decays, n 1335, n_eff 74);
* the encoder's quantization (``estimation.stats.quantization``): the same sample error
  (its variance is Q²/12 plus the residual's excess noise) with the correlation that one
  unknown phase per run puts into it, which the residual cannot show. It is the fit's σ
  where it is the larger (slow motion, little noise to dither the encoder: the 143 kg tows
  of tests/estimation/term_search/test_term_coverage.py);
* the record bootstrap (ν = records − 1);
* the repeatability of repeat campaigns (u = s/√N, ν = N − 1).

A kind's own random sources (a tow's release-timing refit and thrust calibration draws,
``estimation.axis.drive_uncertainty``) are separate and enter as they are.

A seed method (``--method ls-*``) has no output-error fit to read: its random error is its
own regression's σ and ν (``SeedSigma``, ``estimation.axis.seed_methods``: the larger of the
white and the long-run σ, ν = n_eff − p), with the repeatability counted once beside it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from estimation.motion.estimation_result import EstimationResult
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.well_determined import Combination
from estimation.stats.misfit import effective_sample_size
from estimation.uncertainty.rows import BudgetRow, counted_once, repeatability_row

QUANTIZATION = "encoder quantization (step Q, one unknown phase per run)"
FIT_WHITE = "fit (white σ̂²(JᵀJ)⁻¹; ν = n − p)"
FIT_SERIAL = "fit (σ with the residual's correlation; ν = n_eff − p)"
COMBINATION_ROW = "fit (delta method through the coefficients' σ)"
NOT_IDENTIFIED = "not identified by these records: no σ, so no U"
SEED_ROW = "seed regression (larger of white and long-run σ; ν = n_eff − p)"


@dataclass(frozen=True)
class SeedSigma:
    """A seed method's own Type A: σ and ν per coefficient, and its counts (n, n_eff, p)."""

    std: Mapping[str, float]
    dof: Mapping[str, float]
    counts: str


def seed_rows(
    seed: SeedSigma,
    units: Mapping[str, str],
    repeat_std: Mapping[str, tuple[float, int]],
    own_rows: Callable[[str, str], list[BudgetRow]],
) -> dict[str, list[BudgetRow]]:
    """Each coefficient's Type A rows of a seed method (module doc): its regression's σ on
    its ν and the repeatability, counted once, then the kind's ``own_rows``."""
    rows: dict[str, list[BudgetRow]] = {}
    for name, sigma in seed.std.items():
        unit, dof = units.get(name, ""), max(float(seed.dof[name]), 1.0)
        if not math.isfinite(sigma):
            rows[name] = [BudgetRow(SEED_ROW, "A", unit, math.nan, 1.0, math.nan, dof,
                                    note=NOT_IDENTIFIED)]  # fmt: skip
            continue
        random = [BudgetRow(SEED_ROW, "A", unit, float(sigma), 1.0, 0.0, dof, note=seed.counts)]
        if name in repeat_std:
            random.append(repeatability_row(unit, *repeat_std[name]))
        rows[name] = [*counted_once(random), *own_rows(name, unit)]
    return rows


def fit_dof(fit: MotionFit, white: bool) -> tuple[float, str]:
    """ν of the fit's rows (n − p white, n_eff − p otherwise, at least 1) and their note
    (n, n_eff, p); computed once per budget and passed to ``random_rows`` and
    ``combination_rows``."""
    n_eff = effective_sample_size(fit.residuals)
    dof = fit.n_samples - fit.n_params if white else n_eff - fit.n_params
    return max(float(dof), 1.0), f"n = {fit.n_samples}, n_eff = {n_eff:.0f}, p = {fit.n_params}"


def random_rows(
    result: EstimationResult[Any],
    fit: MotionFit,
    units: Mapping[str, str],
    white: bool,
    dof: tuple[float, str],
    repeat_std: Mapping[str, tuple[float, int]],
    own_rows: Callable[[str, str], list[BudgetRow]],
) -> dict[str, list[BudgetRow]]:
    """Each coefficient's Type A rows (module doc): the fit's (white or with the residual's
    correlation), the quantization's, the bootstrap's and the repeatability's, counted once,
    then the kind's ``own_rows``; a coefficient the records do not determine has one row
    without a value (no U); ``dof``: ``fit_dof``'s."""
    dof_fit, counts = dof
    sigma = fit.std_white if white and fit.std_white is not None else fit.std
    boot = result.bootstrap
    rows: dict[str, list[BudgetRow]] = {}
    for i, name in enumerate(fit.names):
        unit = units.get(name, "")
        if not math.isfinite(float(fit.std[i])):  # the data do not determine it: no U at all
            rows[name] = [
                BudgetRow(FIT_WHITE if white else FIT_SERIAL, "A", unit, math.nan, 1.0,
                          math.nan, dof_fit, note=NOT_IDENTIFIED)
            ]  # fmt: skip
            continue
        random = [
            BudgetRow(FIT_WHITE if white else FIT_SERIAL, "A", unit, float(sigma[i]), 1.0, 0.0,
                      dof_fit, note=counts)
        ]  # fmt: skip
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
            random.append(repeatability_row(unit, *repeat_std[name]))
        rows[name] = [*counted_once(random), *own_rows(name, unit)]
    return rows


def combination_rows(
    result: EstimationResult[Any],
    fit: MotionFit,
    white: bool,
    dof: tuple[float, str],
    combinations: Callable[[MotionFit], tuple[Combination, ...]],
) -> dict[str, list[BudgetRow]]:
    """The Type A row of each well-determined combination (a tow's terminal speed, a decay's
    T₀ and ζ), by name: its delta-method σ through the fit's correlation with the
    coefficients' σ as for their rows — the larger of the white and the quantization σ where
    ``white``, the estimate's σ otherwise — on the same ν. The bootstrap, repeatability and a
    kind's own rows are kept per raw coefficient only (docs/uncertainty.md); ``dof``:
    ``fit_dof``'s."""
    dof_fit, counts = dof
    forms = [f for f in (fit.std_white, fit.std_quantization) if f is not None] if white else []
    sigmas: dict[str, list[float]] = {}
    for std in forms:
        for c in combinations(replace(fit, std=std)):
            if c.std is not None:
                sigmas.setdefault(c.name, []).append(c.std)
    out = {}
    for c in result.well_determined:
        found = sigmas.get(c.name, []) if forms else [c.std] if c.std is not None else []
        found = [s for s in found if math.isfinite(s)]
        if c.std is None or not math.isfinite(c.std) or not found:
            row = BudgetRow(COMBINATION_ROW, "A", c.unit, math.nan, 1.0, math.nan, dof_fit,
                            note=NOT_IDENTIFIED)  # fmt: skip
        else:
            u = float(np.max(found))
            row = BudgetRow(COMBINATION_ROW, "A", c.unit, u, 1.0, u, dof_fit, note=counts)
        out[c.name] = [row]
    return out
