"""What the next free decay would teach: each coefficient's σ predicted after one more record
released from a chosen amplitude, from the fit the records already have (the one engine's
model and Jacobian), as the tow planner predicts a tow's (``design.information``).

The planned record is the first record's setting (its sample times from its release, its
known terms and weights) released at rest from x_eq + A. Its information on the
coefficients θ is

    I_A = J_θᵀ·(1 − P_ν)·J_θ / σ²,   J = ∂ξ(t_k)/∂(θ, ν) by central differences,

where ν are the record's own nuisances (its rest position, initial angle and rate: fitted
for every record, so projected out, P_ν = J_ν(J_νᵀJ_ν)⁻¹J_νᵀ) and σ² the fit's residual
variance SSE/(n − p). The records already fitted give I_0 = C_w⁻¹, the inverse of the fit's
own white covariance of the coefficients (``FitStatistics.combinations``), and
(I_0 + I_A)⁻¹ is the white σ after the new record; each coefficient's is then
scaled by the ratio of its reported σ to its white σ now (the serial correlation and
quantization the records show, ``stats.identify``, taken to persist). That is how far one
more record released from A would shrink each σ if the model holds. Candidates: the
records' largest release amplitude times ``AMPLITUDE_FACTORS``; the advice names the one
that shrinks the least-determined coefficient (largest σ/|θ|) the most.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from estimation.motion.kernel import form_of
from estimation.motion.output_error_fit import MotionFit, simulate
from estimation.motion.records import Record, Setup, known_terms_of
from estimation.motion.terms import LIBRARY
from estimation.report_numbers import finite_or_none

#: Release amplitudes tried, as multiples of the largest the records have: one smaller,
#: the same again (a repeat), and two larger.
AMPLITUDE_FACTORS = (0.5, 1.0, 1.5, 2.0)
#: Relative step of the central differences (of each coefficient's size).
DIFF_STEP = 1e-4


@dataclass(frozen=True)
class PlannedRelease:
    """One more record released from ``amplitude`` (m or rad): each coefficient's σ now and
    predicted after it (``names`` order)."""

    amplitude: float
    unit: str
    names: tuple[str, ...]
    std_now: np.ndarray
    std_after: np.ndarray

    def to_json(self, name: Callable[[str], str] = str) -> dict[str, Any]:
        """{amplitude, unit, std_now: {name: σ}, std_after: {name: σ}}; ``name``: what the
        result calls each coefficient."""

        def by_name(std: np.ndarray) -> dict[str, float | None]:
            return {name(n): finite_or_none(s) for n, s in zip(self.names, std, strict=True)}

        return {
            "amplitude": finite_or_none(self.amplitude),
            "unit": self.unit,
            "std_now": by_name(self.std_now),
            "std_after": by_name(self.std_after),
        }


def planned_record(template: Record) -> Record:
    """``template``'s setting (its samples from its first, known terms, weights) as a free
    record: where one more release is integrated (its positions are never read)."""
    t = np.asarray(template.t, dtype=float) - float(template.t[0])
    return replace(template, run_id="planned", t=t, x=np.zeros_like(t), released_at=None)


def _information(
    record: Record, setup: Setup, fit: MotionFit, amplitudes: Sequence[float]
) -> list[np.ndarray]:
    """J_θᵀ·(1 − P_ν)·J_θ of ``record`` released from each of ``amplitudes`` under ``fit``'s
    coefficients (module doc): one integration of every amplitude's perturbed sets, the
    coefficients' and the record's own initial angle and rate. The step is chosen for the
    coefficient sets, the same for every amplitude: each amplitude's columns are the numbers
    its own integration gives."""
    if len(amplitudes) > 1 and amplitudes[0] != 0 and _linear(record, setup, fit.names):
        # ξ(t) is linear in the release: J_θ scales with A, ∂ξ/∂ξ₀ and ∂ξ/∂ξ̇₀ do not, so
        # the projected information scales with A² (the same to round-off, 1e-12)
        first = _information(record, setup, fit, amplitudes[:1])[0]
        return [first * (a / amplitudes[0]) ** 2 for a in amplitudes]
    ng = len(fit.names)
    per = 2 * ng + 4  # sets per amplitude
    h = DIFF_STEP * np.maximum(np.abs(fit.values), 1e-12)
    sets = np.repeat(fit.values[None, :], per, axis=0)
    for i in range(ng):
        sets[2 * i, i] += h[i]
        sets[2 * i + 1, i] -= h[i]
    starts, dx0s, dv0 = [], [], 1e-3
    for a in amplitudes:
        dx0 = DIFF_STEP * max(abs(a), 1e-12)
        s = np.repeat(np.array([[[a, 0.0]]]), per, axis=0)
        s[2 * ng :, 0] += [[dx0, 0.0], [-dx0, 0.0], [0.0, dv0], [0.0, -dv0]]
        starts.append(s)
        dx0s.append(dx0)
    every = np.tile(sets, (len(amplitudes), 1))
    ((xs_all, _),) = simulate([record], setup, fit.names, every, np.concatenate(starts))
    out = []
    for k, dx0 in enumerate(dx0s):
        xs = xs_all[k * per : (k + 1) * per]
        j_theta = np.column_stack([(xs[2 * i] - xs[2 * i + 1]) / (2 * h[i]) for i in range(ng)])
        d_x0 = (xs[2 * ng] - xs[2 * ng + 1]) / (2 * dx0)
        d_v0 = (xs[2 * ng + 2] - xs[2 * ng + 3]) / (2 * dv0)
        out.append(_profiled(j_theta, np.column_stack([np.ones(xs.shape[1]), d_x0, d_v0])))
    return out


def _linear(record: Record, setup: Setup, names: Sequence[str]) -> bool:
    """Whether ``record``'s motion is linear in its initial state: no drive, and every force
    term (identified or known) proportional to x or to ẋ (``kernel.form_of``); the inertia
    terms only scale the inertia."""
    if record.drive is not None:
        return False
    terms = [LIBRARY[n] for n in (*names, *known_terms_of(record, setup)) if n != "inertia"]
    for term in terms:
        if term.role == "inertia":
            continue
        form = form_of(term) if term.role == "force" and not term.set_valued_at_rest else None
        if form is None or (form.x_code, form.v_code) not in ((1, 0), (0, 1)):
            return False
    return True


def _profiled(j_theta: np.ndarray, j_nu: np.ndarray) -> np.ndarray:
    """J_θᵀ·(1 − P_ν)·J_θ: the information on θ with the nuisances ν fitted too."""
    q, _ = np.linalg.qr(j_nu)
    projected = j_theta - q @ (q.T @ j_theta)
    return projected.T @ projected


def next_releases(
    records: Sequence[Record],
    setup: Setup,
    fit: MotionFit,
    amplitudes: Sequence[float],
    unit: str,
) -> tuple[PlannedRelease, ...]:
    """For each of ``amplitudes`` (m or rad), each coefficient's σ now and predicted after one
    more record released from it (module doc); () when the fit's σ are not all known."""
    white, c = fit.std_white, fit.combinations
    if white is None or c is None or not (np.all(np.isfinite(fit.std)) and np.all(white > 0)):
        return ()
    variance = fit.sse / max(fit.n_samples - fit.n_params, 1)
    info_now = np.linalg.inv(c.white)  # I_0, σ² included
    inflation = np.asarray(fit.std) / white
    planned = planned_record(records[0])
    out = []
    for a, added in zip(amplitudes, _information(planned, setup, fit, amplitudes), strict=True):
        info = info_now + added / variance
        after = np.sqrt(np.maximum(np.diag(np.linalg.pinv(info)), 0.0)) * inflation
        out.append(PlannedRelease(float(a), unit, fit.names, np.asarray(fit.std), after))
    return tuple(out)


def best_release(
    planned: Sequence[PlannedRelease], values: np.ndarray
) -> tuple[PlannedRelease, str] | None:
    """The candidate that most shrinks the least-determined coefficient (largest σ/|θ| now)
    and that coefficient's name; None without candidates."""
    if not planned:
        return None
    first = planned[0]
    relative = first.std_now / np.maximum(np.abs(values), 1e-300)
    worst = int(np.argmax(relative))
    best = min(planned, key=lambda p: p.std_after[worst])
    return best, first.names[worst]


def release_advice(
    planned: Sequence[PlannedRelease], values: np.ndarray, largest: float, named: str
) -> str | None:
    """The sentence naming the next decay to run (``best_release``), its coefficient called
    ``named`` (the result's name for it); None without candidates."""
    chosen = best_release(planned, values)
    if chosen is None:
        return None
    best, name = chosen
    i = best.names.index(name)
    again = "again " if np.isclose(best.amplitude, largest) else ""
    degrees = f" = {np.degrees(best.amplitude):.3g}°" if best.unit == "rad" else ""
    return (
        f"the next decay to run: released {again}from {best.amplitude:.3g} {best.unit}{degrees} "
        f"({best.amplitude / largest:g}× the largest release so far) would bring σ of {named} "
        f"from {best.std_now[i]:.2g} to {best.std_after[i]:.2g} (predicted from this fit, "
        "if its model holds)"
    )
