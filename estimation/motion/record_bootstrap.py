"""The record-level bootstrap of the one fit, every record kind's (tows and spins, pendulums
and free decays): the records resampled with replacement and refitted, σ and the 2.5/97.5 %
percentiles of the draws per coefficient.

Each draw is ``fit_motion`` of the resampled records with the final model's terms, from its
coefficients and each record's own nuisances; only its coefficients are kept, so only they
are computed (``fitted_values``: no σ, no residual statistics). A sample the kind cannot
fit meaningfully is skipped (``usable``: a tow set with fewer distinct drives than its
data, where K_L and K_Q trade freely). Fewer than ``MIN_RECORDS`` records: no draws — two
records have three distinct resamples, two of them one record twice, and a tow pair only
one usable (the set itself): its "spread" of 0 would claim a precision the records do not
have. Fewer than ``MIN_DISTINCT`` distinct resamples among the usable draws: no spread
either, for the same reason. A resample drawn again (the same records in the same order: 4
of 40 draws of 4 records, 19 of 3) reuses its refit. The spread of the draws is the
between-record scatter the fit's σ assumes away: a σ well below it says the records
disagree more than their noise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.motion.output_error_fit import MotionFit, fitted_values, parameters_of
from estimation.motion.records import Record, Setup
from estimation.report_numbers import finite_values

#: Draws of an estimate's bootstrap unless asked otherwise.
DEFAULT_DRAWS = 40
#: Function evaluations of one draw (a draw starts from the final coefficients).
DRAW_NFEV = 200
#: Records a resampling needs (module doc).
MIN_RECORDS = 3
#: Distinct resamples (sets of records, in any order) a spread needs (module doc).
MIN_DISTINCT = 3


@dataclass(frozen=True)
class Bootstrap:
    """Record-level bootstrap: records resampled with replacement and refitted."""

    requested: int
    used: int
    std: dict[str, float]
    low: dict[str, float]  # 2.5 % percentile
    high: dict[str, float]  # 97.5 % percentile

    def to_json(self, name: Callable[[str], str] | None = None) -> dict[str, Any]:
        """The document's ``bootstrap`` object (non-finite values as null), each coefficient
        under ``name(coefficient)`` (the kind's own name for it; default its own)."""

        def named(values: dict[str, float]) -> dict[str, float | None]:
            return finite_values({(name or str)(k): v for k, v in values.items()})

        return {
            "requested": self.requested,
            "used": self.used,
            "std": named(self.std),
            "percentile_2_5": named(self.low),
            "percentile_97_5": named(self.high),
        }


def record_bootstrap(
    records: Sequence[Record],
    setup: Setup,
    fit: MotionFit,
    n: int,
    seed: int = 0,
    usable: Callable[[Sequence[Record]], bool] | None = None,
) -> Bootstrap:
    """``n`` draws of the records refitted with ``fit``'s terms (module doc)."""
    rng = np.random.default_rng(seed)
    draws: list[np.ndarray] = []
    requested = n if len(records) >= MIN_RECORDS else 0
    done: dict[tuple[int, ...], np.ndarray] = {}  # a resample drawn again: its refit, reused
    kinds: set[tuple[int, ...]] = set()  # the distinct resamples used (sets, any order)
    for _ in range(requested):
        pick = tuple(int(i) for i in rng.integers(0, len(records), len(records)))
        sample = [records[i] for i in pick]
        if usable is not None and not usable(sample):
            continue
        if pick not in done:  # the refit is deterministic: the same draw, bit for bit
            done[pick] = fitted_values(
                sample, setup, fit.effects, parameters_of(fit, pick), DRAW_NFEV
            )
        draws.append(done[pick])
        kinds.add(tuple(sorted(pick)))
    names = fit.names
    if len(kinds) < MIN_DISTINCT:
        draws = []
    if not draws:
        nan = dict.fromkeys(names, float("nan"))
        return Bootstrap(requested, 0, nan, nan, nan)
    arr = np.array(draws)
    std = arr.std(axis=0, ddof=1) if len(draws) > 1 else np.full(len(names), np.nan)
    return Bootstrap(
        requested=requested,
        used=len(draws),
        std={k: float(v) for k, v in zip(names, std, strict=True)},
        low={k: float(v) for k, v in zip(names, np.percentile(arr, 2.5, axis=0), strict=True)},
        high={k: float(v) for k, v in zip(names, np.percentile(arr, 97.5, axis=0), strict=True)},
    )
