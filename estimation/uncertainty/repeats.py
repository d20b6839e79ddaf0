"""The repeatability row of a tow set's uncertainty budget: N repeat campaigns refitted
(ITTC 7.5-02-01-01 §2.4); which runs repeat which is ``estimation.axis.tow_repeats``'s."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.kind_advice import ADVICE, KindAdvice
from estimation.motion.output_error_fit import MotionFit
from estimation.stats.repeatability import RepeatAnalysis, campaign_repeatability


def repeat_campaign_std(
    runs: Sequence[RunData],
    fit: MotionFit,
    analysis: RepeatAnalysis,
    advice: KindAdvice = ADVICE["tow"],
) -> tuple[dict[str, tuple[float, int]], str]:
    """Repeatability of each coefficient from N repeat campaigns (``runs`` as fitted, their
    releases refined): campaign k takes the k-th
    repeat of every condition and is fitted on its own; u = s/√N with ν = N − 1 (the
    standard deviation of the mean of N campaigns, ITTC 7.5-02-01-01 §2.4).
    Returns ({name: (u, N)}, a note when it cannot be evaluated, whose advice is
    ``advice``'s: a rig's sequence, or more imported records)."""
    index = {r.run_id: r for r in runs}
    groups = [[index[i] for i in c.run_ids if i in index] for c in analysis.conditions]
    groups = [g for g in groups if g]

    def refit(campaign: list[RunData]) -> np.ndarray:
        prepared = [prepare(r) for r in campaign]
        return fit_output_error(
            prepared, fit.effects, start=fit.values, quantization_sigma=False
        ).values

    spread, n = campaign_repeatability(groups, fit.names, refit)
    if n >= 2:
        return spread, ""
    return {}, (
        "repeatability not evaluated: no condition was run more than once (ITTC names "
        f"run-to-run scatter the largest source in practice; {advice.repeat_runs}, ≥ 5 "
        "for Chauvenet's criterion to be able to flag an outlier)"
        if not any(len(g) > 1 for g in groups)
        else "repeatability not evaluated: some conditions were run only once"
    )
