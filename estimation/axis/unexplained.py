"""Structure the final model still lacks: flagged, characterised, never absorbed.

After the effect search, the residual should be what the encoder and the clock leave: white
and at the noise floor the fit itself implies (``diagnostics.force_noise_floor``). When it is
neither — the force-domain residual is well above that floor, decisively
(``stats.misfit.structured``: by Ljung–Box, or by its excess on the effective sample size,
which a short record can reach) — something outside the effect library acts on the vehicle.
It is characterised, not fitted: its correlation with position, velocity, time since release
and acceleration, and the dominant period of a sinusoid in position or in time (the share of
the force residual it explains, from a least-squares periodogram, per run with its own
amplitude and phase). The period scan is the costliest part (~300 sinusoids per run and
domain) and only a report reads it (the result's document, a warning's words): it runs when
``Unexplained.period`` is first read, on the moving samples copied at the verdict, so it gives
the numbers it gave when it ran inside ``characterise`` (a flagged residual's ``strongest``
reads it there).
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from estimation.axis.force_residual import force_noise_floor, force_residuals
from estimation.axis.prepared_run import PreparedRun
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.terms import force_unit
from estimation.report_numbers import finite_or_none, finite_values
from estimation.stats.acceptance_rules import NUMERICAL_SHARE
from estimation.stats.diagnostics import ljung_box
from estimation.stats.misfit import effective_sample_size, structured

PERIODIC_SHARE = 0.3  # a sinusoid explaining this share of the residual is called periodic
N_FREQUENCIES = 300
#: Frequencies per block of the sinusoid fit (``_sinusoid_fit``), at least; more while a
#: block has fewer than ``SINUSOID_CELLS`` (frequency, sample) cells.
SINUSOID_BLOCK, SINUSOID_CELLS = 32, 16384


@dataclass(frozen=True)
class Period:
    """The strongest sinusoid in the force residual."""

    domain: str  # "position" or "time"
    value: float  # period, in the domain's unit
    unit: str
    share: float  # fraction of the force residual's variance it explains


class PeriodScan:
    """The strongest sinusoid of a force residual (``_dominant_period``), scanned when first
    asked for and kept: per domain, each run's moving coordinates and forces (copies)."""

    def __init__(self, parts: dict[str, list[tuple[np.ndarray, np.ndarray]]], axis: str) -> None:
        self._parts, self._axis = parts, axis

    @functools.cached_property
    def period(self) -> Period | None:
        return _dominant_period(self._parts, self._axis)


@dataclass(frozen=True)
class Unexplained:
    """How much structure is left after the search, and what it looks like."""

    structured: bool
    ljung_box_p: float
    force_rms: float  # N or N·m
    noise_floor: float  # N or N·m
    correlations: dict[str, float]  # Pearson r with position, velocity, time, acceleration
    scan: PeriodScan = field(repr=False, compare=False)  # ``period``, when first read
    strongest: str | None  # "position", "velocity", "time", "acceleration", or None

    @property
    def period(self) -> Period | None:
        """The strongest sinusoid in the force residual (None: none but a trend)."""
        return self.scan.period

    @property
    def ratio(self) -> float:
        """Force residual RMS over the noise floor (≈ 1 when only noise is left)."""
        return self.force_rms / self.noise_floor if self.noise_floor > 0 else float("inf")

    def evidence(self, axis: str) -> str:
        """What the residual shows, in words: its Ljung–Box p, force RMS over the noise floor,
        and its strongest correlate or sinusoid."""
        where = f"strongest correlate: {self.strongest}" if self.strongest else "no clear correlate"
        if self.period is not None and self.period.share >= PERIODIC_SHARE:
            where = (
                f"periodic in {self.period.domain} with period {self.period.value:.3g} "
                f"{self.period.unit} ({self.period.share:.0%} of it)"
            )
        elif self.period is not None:  # named, with its share, though it is not most of it
            where += (
                f"; strongest sinusoid in {self.period.domain}: period "
                f"{self.period.value:.3g} {self.period.unit} ({self.period.share:.0%} of it)"
            )
        return (
            f"(Ljung–Box p = {self.ljung_box_p:.2g}; force residual {self.force_rms:.3g} "
            f"{force_unit(axis)}, "
            f"{self.ratio:.1f}× the noise floor the fit implies); {where}"
        )

    def warning(self, axis: str, searched: bool = True) -> str | None:
        """One sentence for ``warnings``, or None when nothing structured is left
        (``searched``: whether the effect search ran; if not, the sentence asks for it)."""
        if not self.structured:
            return None
        evidence = self.evidence(axis)
        if not searched:
            return (
                f"the residual is structured {evidence}; the effect search was off, so no "
                "effect was tried: estimate again with it on (the default); the coefficients "
                "may be biased by it"
            )
        return (
            f"the residual is still structured after the effect search {evidence}; no effect "
            "in the library explains it, so none was added: the coefficients may be biased by it"
        )

    def seed_warning(
        self, method: str, axis: str, output_error: Unexplained, concluded: bool = False
    ) -> str:
        """One sentence for a seed method's result whose coefficients misfit the records
        (its residual is ``structured``). ``output_error``: the same verdict on
        the output-error fit of the same runs (the base model, no effect searched), which
        says whose model the structure belongs to: the seed method's own (its derivatives,
        first-order curves or steady speeds are not the equation's solution) when output
        error leaves the record at its floor, the record's (a force neither model has)
        when it does not. A seed σ rests on the method's own regression and can be large
        enough to hide a bias from ``method_bias``; the positions it predicts cannot.
        ``concluded``: ``method_bias`` already told the user what to sign, so the sentence
        ends with the evidence."""
        head = (
            f"{method}'s coefficients do not reproduce the runs: simulated with them, the "
            f"residual is structured {self.evidence(axis)}"
        )
        if output_error.structured:
            return (
                f"{head}; the output-error fit of the same runs leaves "
                f"{output_error.ratio:.1f}× its floor too: the record holds a force neither "
                "model has; estimate with output-error, whose effect search looks for it"
            )
        head += f", where the output-error fit of the same runs leaves {output_error.ratio:.1f}×"
        if concluded:
            return head
        return (
            f"{head}: the method's own model misfits the record, so its coefficients may be "
            "biased, and their U does not cover that: sign the output-error result"
        )

    def to_json(self) -> dict[str, Any]:
        """The ``unexplained`` field of the result document."""
        return {
            "structured": self.structured,
            "coefficients_possibly_biased": self.structured,
            "ljung_box_p": finite_or_none(self.ljung_box_p),
            "force_rms": finite_or_none(self.force_rms),
            "noise_floor": finite_or_none(self.noise_floor),
            "ratio_to_noise_floor": finite_or_none(self.ratio),
            "correlations": finite_values(self.correlations),
            "strongest": self.strongest,
            "period": None
            if self.period is None
            else {
                "domain": self.period.domain,
                "value": finite_or_none(self.period.value),
                "unit": self.period.unit,
                "share": finite_or_none(self.period.share),
            },
        }


def characterise(fit: MotionFit, runs: Sequence[PreparedRun], axis: str) -> Unexplained:
    """Flag and describe what ``fit`` leaves unexplained in ``runs`` (module doc)."""
    forces = force_residuals(fit, runs)
    moving = [r.t > r.t_release for r in runs]
    pooled = np.concatenate([f[m] for f, m in zip(forces, moving, strict=True)])
    force_rms = float(np.sqrt(np.mean(pooled**2))) if pooled.size else 0.0
    floor = force_noise_floor(fit, runs)
    p_value = ljung_box(fit.residuals).p_value
    travel = max((float(np.ptp(r.x)) for r in runs), default=0.0)
    numerical = fit.rmse <= NUMERICAL_SHARE * travel  # noise-free data: round-off is no force
    moving_forces = [f[m] for f, m in zip(forces, moving, strict=True)]
    ratio = force_rms / floor if floor > 0 else float("inf")
    flagged = structured(p_value, ratio, effective_sample_size(moving_forces)) and not numerical
    coords = _coordinates(fit, runs)
    correlations = {
        name: _pearson(pooled, np.concatenate([c[m] for c, m in zip(cols, moving, strict=True)]))
        for name, cols in coords.items()
    }
    along = {"position": [np.asarray(r.x) for r in runs], "time": coords["time"]}
    scan = PeriodScan(
        {
            domain: [(c[m], f[m]) for c, f, m in zip(along[domain], forces, moving, strict=True)]
            for domain in ("position", "time")
        },
        axis,
    )
    strongest = None
    if flagged:
        strongest = max(correlations, key=lambda k: abs(correlations[k]))
        period = scan.period
        if period is not None and period.share >= max(PERIODIC_SHARE, correlations[strongest] ** 2):
            strongest = period.domain
    return Unexplained(flagged, p_value, force_rms, floor, correlations, scan, strongest)


def _coordinates(fit: MotionFit, runs: Sequence[PreparedRun]) -> dict[str, list[np.ndarray]]:
    """Per run: displacement since release, model velocity, time since release, acceleration."""
    out: dict[str, list[np.ndarray]] = {
        k: [] for k in ("position", "velocity", "time", "acceleration")
    }
    for r, offset, v in zip(runs, fit.equilibrium, fit.velocities, strict=True):
        out["position"].append(r.x - offset)
        out["velocity"].append(v)
        out["time"].append(r.t - r.t_release)
        out["acceleration"].append(np.gradient(v, r.t) if r.t.size > 1 else np.zeros_like(v))
    return out


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a - a.mean(), b - b.mean()
    denom = float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(a @ b) / denom if denom > 0 else 0.0


def _dominant_period(
    moving_parts: dict[str, list[tuple[np.ndarray, np.ndarray]]], axis: str
) -> Period | None:
    """The sinusoid that explains most of the force residual (``moving_parts``: per domain,
    each run's moving coordinates and forces): in rail position (the encoder's reading, so
    a feature of the rail lines up across runs) or in time since release. A domain whose
    best fit is the longest period tried (2/3 of the longest run) has a trend there, not a
    period: a drift the model's law misses (a seed method's) is not named a sinusoid."""
    units = {"position": "m" if axis == "surge" else "rad", "time": "s"}
    best: Period | None = None
    for domain, unit in units.items():
        parts = [(u, f) for u, f in moving_parts[domain] if u.size >= 10 and np.ptp(u) > 0]
        if not parts:
            continue
        step = float(np.median(np.concatenate([np.abs(np.diff(u)) for u, _ in parts])))
        longest = max(float(np.ptp(u)) for u, _ in parts)
        shortest = 2.5 * step
        if not 0 < shortest < longest / 1.5:
            continue
        periods = np.geomspace(shortest, longest / 1.5, N_FREQUENCIES)
        total = sum(float(np.sum((f - f.mean()) ** 2)) for _, f in parts)
        if total <= 0:
            continue
        explained = np.zeros(periods.size)
        for u, f in parts:
            explained += _sinusoid_fit(u, f - f.mean(), 2 * np.pi / periods)
        k = int(np.argmax(explained))
        if k == periods.size - 1:  # best at the longest period tried: a trend, not a period
            continue
        share = float(explained[k] / total)
        if best is None or share > best.share:
            best = Period(domain, float(periods[k]), unit, share)
    return best


def _sinusoid_fit(u: np.ndarray, f: np.ndarray, omegas: np.ndarray) -> np.ndarray:
    """Variance of ``f`` (centred) explained by a·sin(ωu) + b·cos(ωu) + c, for each ω; in
    blocks of ``SINUSOID_BLOCK`` frequencies, so the sines, cosines and their products stay
    in the cache (the whole (ω, u) grid does not: 300 ω × 3000 samples 72 → 25 ms, × 200
    samples 2.7 → 2.1 ms). Each ω's numbers are its own row's, as on the whole grid; only
    the BLAS products s·f, c·f may round differently in the last bit on long records."""
    explained = np.empty(omegas.size)
    rows = max(SINUSOID_BLOCK, SINUSOID_CELLS // max(u.size, 1))  # a short record: one block
    for k in range(0, omegas.size, rows):
        explained[k : k + rows] = _sinusoid_block(u, f, omegas[k : k + rows])
    return explained


def _sinusoid_block(u: np.ndarray, f: np.ndarray, omegas: np.ndarray) -> np.ndarray:
    phase = np.outer(omegas, u)
    s, c = np.sin(phase), np.cos(phase)
    s -= s.mean(axis=1, keepdims=True)
    c -= c.mean(axis=1, keepdims=True)
    ss, cc, sc = (s * s).sum(1), (c * c).sum(1), (s * c).sum(1)
    sf, cf = s @ f, c @ f
    det = ss * cc - sc**2
    ok = det > 1e-12 * np.maximum(ss * cc, 1e-300)
    a = np.where(ok, (cc * sf - sc * cf) / np.where(ok, det, 1.0), 0.0)
    b = np.where(ok, (ss * cf - sc * sf) / np.where(ok, det, 1.0), 0.0)
    return a * sf + b * cf
