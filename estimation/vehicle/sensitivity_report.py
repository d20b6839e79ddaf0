"""The sensitivity analysis's report (``estimation.vehicle.sensitivity.analyse``): a row
per coefficient (S, Sc, composite index, ±σ change), a row per threshold of the sweep, and
how the composite rule's removals depend on the response weights (no new simulations)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from estimation.report_numbers import finite_or_none, finite_values
from estimation.vehicle.responses import Plan

#: Weight stability: each response's weight is multiplied and divided by this.
WEIGHT_FACTOR = 2.0


@dataclass(frozen=True)
class CoefficientRow:
    """One coefficient's sensitivities; dicts are keyed by response name."""

    name: str
    value: float
    sigma: float | None
    candidate: bool  # may be removed (non-zero, not kept)
    keep: bool
    s: dict[str, float | None]  # None: H = 0 (no relative change of H)
    sc: dict[str, float]
    composite: float
    max_sc: float
    sigma_change: dict[str, float] | None  # None: no σ for this coefficient

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "value": self.value,
            "sigma": self.sigma,
            "candidate": self.candidate,
            "keep": self.keep,
            "s": finite_values(self.s),
            "sc": finite_values(self.sc),
            "composite": finite_or_none(self.composite),
            "max_sc": finite_or_none(self.max_sc),
            "sigma_change": None if self.sigma_change is None else finite_values(self.sigma_change),
        }


@dataclass(frozen=True)
class SweepRow:
    """The reduced model at one threshold: what was removed and its error per response."""

    criterion: str  # "composite" (seed rule) or "max" (largest single-response Sc)
    threshold: float
    removed: tuple[str, ...]
    errors: dict[str, float]
    max_error: float
    worst_response: str
    weighted_error: float
    settled: bool

    def to_json(self) -> dict:
        return {
            "criterion": self.criterion,
            "threshold": self.threshold,
            "removed": list(self.removed),
            "n_removed": len(self.removed),
            "errors": finite_values(self.errors),
            "max_error": finite_or_none(self.max_error),
            "worst_response": self.worst_response,
            "weighted_error": finite_or_none(self.weighted_error),
            "settled": self.settled,
        }


@dataclass(frozen=True)
class SensitivityReport:
    """Everything :func:`analyse` found; ``rows`` are ranked by composite index."""

    vehicle: str
    plan: Plan
    reference: dict[str, float]
    modes: dict[str, str]  # response → "relative" | "range"
    scales: dict[str, float]  # the divisor used per response
    weights: dict[str, float]
    ahp: dict | None
    delta: float
    rows: tuple[CoefficientRow, ...]
    zero: tuple[str, ...]  # coefficients already 0 (structural zeros)
    sweep: tuple[SweepRow, ...]
    notes: tuple[str, ...]
    simulations: int
    elapsed_s: float
    weight_stability: tuple[dict, ...] = ()
    identifiability: dict | None = field(default=None)

    def row(self, name: str) -> CoefficientRow:
        for r in self.rows:
            if r.name == name:
                return r
        raise KeyError(name)

    def to_json(self) -> dict:
        units = {r.name: r.unit for r in self.plan.responses}
        return {
            "vehicle": self.vehicle,
            "plan": self.plan.to_json(),
            "reference": {
                k: {
                    "value": finite_or_none(v),
                    "unit": units[k],
                    "mode": self.modes[k],
                    "scale": finite_or_none(self.scales[k]),
                }
                for k, v in self.reference.items()
            },
            "weights": dict(self.weights),
            "ahp": self.ahp,
            "delta": self.delta,
            "ranking": [r.to_json() for r in self.rows],
            "zero": list(self.zero),
            "sweep": [s.to_json() for s in self.sweep],
            "notes": list(self.notes),
            "simulations": self.simulations,
            "elapsed_s": self.elapsed_s,
            "weight_stability": list(self.weight_stability),
            "identifiability": self.identifiability,
        }


def weight_stability(
    rows: Sequence[CoefficientRow],
    weights: Mapping[str, float],
    thresholds: Sequence[float],
    factor: float = WEIGHT_FACTOR,
) -> list[dict]:
    """How the composite-rule removals depend on the weights (no new simulations).

    For each response, its weight is multiplied and divided by ``factor`` (the others
    renormalised); returned are the cases where a threshold would then remove a different
    set of candidates: ``{response, factor, threshold, now_removed, now_kept}``.
    """
    names = list(weights)
    out = []
    base = _removed(rows, weights, thresholds)
    for n in names if len(names) > 1 else ():
        for f in (factor, 1 / factor):
            changed = {k: w * (f if k == n else 1.0) for k, w in weights.items()}
            total = sum(changed.values())
            changed = {k: w / total for k, w in changed.items()}
            for t, removed in _removed(rows, changed, thresholds).items():
                gained, lost = removed - base[t], base[t] - removed
                if gained or lost:
                    out.append(
                        {
                            "response": n,
                            "factor": f,
                            "threshold": t,
                            "now_removed": sorted(gained),
                            "now_kept": sorted(lost),
                        }
                    )
    return out


def _removed(
    rows: Sequence[CoefficientRow], weights: Mapping[str, float], thresholds: Sequence[float]
) -> dict[float, set[str]]:
    composite = {r.name: sum(r.sc[n] * w for n, w in weights.items()) for r in rows}
    return {t: {r.name for r in rows if r.candidate and composite[r.name] < t} for t in thresholds}
