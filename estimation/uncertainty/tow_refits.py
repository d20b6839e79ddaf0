"""How a tow or spin set is re-fitted for its uncertainty budget (``uncertainty.budget``'s
``Refits``): the runs as the estimator would have seen them had a rig constant of the
measurement chain been off by δ (``uncertainty.sources``), a repeat campaign alone, and the
tow's own random sources (release timing, thrust calibration draws). What re-fits them is the
estimate's own method (``Refit``): the output-error fit, or a seed method (``seed_refit``), so
a seed method's Type B sensitivity is its own."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import PreparedRun, prepare
from estimation.axis.tow_estimate import combination_conditions, seed_fit, well_determined
from estimation.axis.tow_section import TowResult
from estimation.data.run_arrays import RunData
from estimation.errors import EstimationFailed
from estimation.kind_advice import advice_for
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.well_determined import Combination
from estimation.uncertainty.budget import DeclaredInput
from estimation.uncertainty.rows import BudgetRow
from estimation.uncertainty.sources import (
    SOURCES,
    Chain,
    check_tolerances,
    perturbed,
    reaches,
    weight_groups,
)
from estimation.uncertainty.type_a import SeedSigma

TYPE_B_NOT_DECLARED = (
    "Type B not declared: the rig file has no [tolerances] section, so U covers the Type A "
    f"sources only ({advice_for('tow').declare_tolerances})"
)
#: The same for runs that came without a rig file (imported data): no section to add to.
TYPE_B_NO_RIG_FILE = (
    "Type B not declared: these runs came without a rig file, so the drive and the rig's "
    "constants are taken as exact and U covers the Type A sources only "
    f"({advice_for('import').declare_tolerances})"
)


#: How an estimate's runs are re-fitted: (the runs moved, prepared; the estimate's fit) → fit.
Refit = Callable[[list[PreparedRun], MotionFit], MotionFit]


def output_error_refit(prepared: list[PreparedRun], fit: MotionFit) -> MotionFit:
    """The output-error fit of ``prepared`` with ``fit``'s effects, started at its values."""
    return fit_output_error(prepared, fit.effects, start=fit.values, quantization_sigma=False)


def seed_refit(method: str) -> Refit:
    """The seed ``method`` (``estimation.axis.seed_methods``) as a ``Refit``; a re-fit its
    numerics refuse (a curve fit that does not converge, one drive left) raises
    ``EstimationFailed``, which the budget names in a note."""

    def refit(prepared: list[PreparedRun], _fit: MotionFit) -> MotionFit:
        try:
            return seed_fit(method, prepared)[0]
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as err:
            raise EstimationFailed(f"the {method} seed method", str(err)) from err

    return refit


def seed_sigma(result: TowResult) -> SeedSigma | None:
    """A seed result's own σ and ν (``TowSection.seed``); None for output error."""
    ls = result.section.seed
    if ls is None:
        return None
    std = dict(zip(ls.names, ls.std.tolist(), strict=True))
    return SeedSigma(std, dict(zip(ls.names, ls.dof.tolist(), strict=True)), ls.counts)


def as_fitted(runs: Sequence[RunData], result: TowResult) -> list[RunData]:
    """The runs with the release instants the estimate fitted with: a release found in the
    data was refined by the fit (``estimation.axis.release.fit_release``), and the result's
    window holds the refined instant (refining again would repeat the costliest step of an
    estimate: 95 s on the ship2d record)."""
    out = []
    for r in runs:
        w = result.section.windows.get(r.run_id)
        if w is not None and r.window_found is not None and w != r.window_found:
            r = replace(r, t_release=w.t_release, window_found=w)
        out.append(r)
    return out


class TowRefits:
    """A tow or spin set's re-fits. ``chain``: the rig constants the runs' drives were
    computed with (None: runs without a rig file, e.g. imported; their advice names the
    import's options, not a section of a file they never had); ``refit``: the estimate's
    method (a seed result's: ``seed_refit(result.method)``)."""

    def __init__(
        self,
        runs: Sequence[RunData],
        result: TowResult,
        chain: Chain | None,
        refit: Refit = output_error_refit,
    ) -> None:
        fit = result.fit_after
        if fit is None:
            raise ValueError(
                "result: got an estimate without its fit, allowed: an output-error fit"
            )
        self.result, self.fit, self.refit = result, fit, refit
        self.runs = as_fitted(runs, result)
        self.chain = chain or Chain(g=9.81)
        self.kind = "import" if chain is None else "tow"
        self.not_declared = TYPE_B_NO_RIG_FILE if chain is None else TYPE_B_NOT_DECLARED
        # the drives and reached speeds the combinations are stated at: one for every re-fit
        self.conditions = combination_conditions(fit, self.runs)
        self._weights = weight_groups(self.runs)
        # the runs as fitted, prepared once: a re-fit reuses a run its source leaves as it
        # is, and the encoder step of positions it leaves as they are
        self._prepared = [prepare(r) for r in self.runs]

    def inputs(
        self, tolerances: Mapping[str, float]
    ) -> tuple[dict[str, float], list[DeclaredInput], list[str]]:
        """The rig file's declared tolerances (``uncertainty.sources``); an input that moves
        no run of this estimate (the water temperature, a thrust calibration in a weight-
        driven fit) is named among the others."""
        declared = check_tolerances(tolerances)
        axis = self.runs[0].axis
        inputs, idle = [], []
        for name, half_width in declared.items():
            source = SOURCES[name]
            if axis not in source.axes or half_width <= 0:
                continue
            parts = len(self._weights) if source.per_weight else 1
            declared_input = DeclaredInput(name, half_width, source.unit, source.meaning, parts)
            if not reaches(self.runs, self.chain, name, declared_input.u):
                idle.append(f"{name} (±{half_width:g} {source.unit}: {source.meaning})")
                continue
            inputs.append(declared_input)
        return declared, inputs, idle

    def moved(
        self, declared: DeclaredInput, delta: float, part: int
    ) -> tuple[MotionFit, tuple[Combination, ...]]:
        only = self._weights[part] if SOURCES[declared.name].per_weight else []
        changed = perturbed(self.runs, self.chain, declared.name, delta, only)
        moved = [self._prepare(i, r) for i, r in enumerate(changed)]
        fit = self.refit(moved, self.fit)
        return fit, self.combinations(fit)

    def combinations(self, fit: MotionFit) -> tuple[Combination, ...]:
        return well_determined(fit, *self.conditions, self.runs[0].axis)

    def campaign(self, run_ids: Sequence[str]) -> MotionFit:
        index = {r.run_id: p for r, p in zip(self.runs, self._prepared, strict=True)}
        prepared = [index[i] for i in run_ids if i in index]
        return self.refit(prepared, self.fit)

    def _prepare(self, i: int, run: RunData) -> PreparedRun:
        """Run ``i`` as a re-fit moved it, prepared (the nominal one when it is unmoved)."""
        nominal, prepared = self.runs[i], self._prepared[i]
        if run is nominal:
            return prepared
        return prepare(run, prepared.encoder_step if run.position is nominal.position else None)

    def own_rows(self, name: str, unit: str) -> list[BudgetRow]:
        """The release-timing refit's and the thrust calibration draws' rows
        (``estimation.axis.drive_uncertainty``), where the estimate has them."""
        drive = self.result.section.uncertainty
        out = []
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
        if drive is not None and drive.draws > 1 and math.isnan(drive.std_calibration[name]):
            out.append(  # said, never a silently smaller U
                BudgetRow(
                    f"thrust calibration ({drive.draws} curve draws)",
                    "A",
                    unit,
                    math.nan,
                    1.0,
                    0.0,
                    drive.draws - 1,
                    combined=False,
                    note="a curve draw did not fit by this estimate's method: not in U",
                )
            )
        return out
