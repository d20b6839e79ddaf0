"""The axis estimator's uncertainty budget: the rig file's constants and ``[tolerances]``
handed to ``estimation.uncertainty`` as plain numbers (estimation never reads a rig file).

The axis entry (``daq.estimators.AXIS``) offers ``fitted_budget`` after its fit (which
compared the repeats and left out the flagged ones when asked, as every estimator's does);
the estimation job calls what the entry offers, naming no estimator. A campaign stops on
the budget's U.
"""

from __future__ import annotations

from collections.abc import Sequence

from daq.config import RigConfig, RigConfigError, parse_rig_text
from daq.store import RunInfo
from estimation.axis.tow_section import TowResult
from estimation.data.run_arrays import RunData
from estimation.stats.repeatability import RepeatAnalysis
from estimation.uncertainty import Chain, TowRefits, uncertainty_budget
from estimation.uncertainty.budget import Budget
from estimation.uncertainty.tow_refits import output_error_refit, seed_refit, seed_sigma


def rig_of_runs(records: Sequence[RunInfo]) -> RigConfig | None:
    """The rig file the first of the runs' ``records`` was recorded with (None: imported data
    without one)."""
    for run in records:
        text = run.rig_toml
        if text:
            try:
                return parse_rig_text(text, f"run {run.id} rig file")
            except RigConfigError:
                return None
    return None


def chain_of(rig: RigConfig) -> Chain:
    """The constants a weight-driven run's drive and inertia were computed with."""
    geo = rig.geometry
    return Chain(
        g=rig.rig.g,
        pulley_radius_m=geo.pulley_radius_m,
        pulley_inertia_kg_m2=geo.pulley_inertia_kg_m2,
        drum_radius_m=geo.spin_drum_radius_m,
        drum_inertia_kg_m2=geo.spin_drum_inertia_kg_m2,
    )


def tolerances_of(rig: RigConfig | None) -> dict[str, float]:
    """The rig file's declared tolerances ({} when it has no ``[tolerances]``)."""
    return {} if rig is None or rig.tolerances is None else rig.tolerances.declared()


def fitted_budget(
    records: Sequence[RunInfo],
    runs: Sequence[RunData],
    result: TowResult,
    repeats: RepeatAnalysis | None = None,
) -> Budget | None:
    """The uncertainty budget of ``result`` of ``runs`` with the rig file's constants and
    tolerances (their ``records'``): an output-error result's, or a seed method's (its own
    σ and ν, its Type B by re-fitting the seed method); None without a fit."""
    if result.fit_after is None:
        return None
    rig = rig_of_runs(records)
    seed = seed_sigma(result)
    refit = output_error_refit if seed is None else seed_refit(result.method)
    refits = TowRefits(runs, result, chain_of(rig) if rig else None, refit)
    return uncertainty_budget(result, refits, tolerances_of(rig), repeats, seed=seed)
