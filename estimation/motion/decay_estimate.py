"""The entry for a record of one DOF: ``estimate_decay`` (free decay, forced, or pulled).

    (M_known + M)·ẍ + B₁·ẋ + [B₂·|ẋ|·ẋ + B₃·ẋ³ + F_c·sign ẋ] + k·x + [k₃·x³] = τ(t)

(terms in brackets are library candidates, kept by the one search, ``motion.term_search``).
A free decay scales every coefficient alike, so it needs one fact from outside: a stiffness (ρ·g·A_w
for heave, Δ·g·GM for roll) or the inertia. The result's warnings name every coefficient
the data do not determine, every value a body cannot have, and — when the residual is
decisively not white (Ljung–Box p < ``WHITE_P``) and the coefficients move by more than
``MOVED_SIGMAS`` σ when a candidate is added or left out, or when the residual is structured
by the rule every record shares (``stats.misfit``: well above the noise floor, decisively) —
that the coefficients may be biased; and every kept term within 2σ
of zero by the σ that counts the residual's correlation (the information criterion that kept
it takes the residual as white).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from estimation.blas_threads import one_blas_thread
from estimation.data.window import encoder_quantum
from estimation.design.decay_information import (
    AMPLITUDE_FACTORS,
    PlannedRelease,
    best_release,
    next_releases,
    release_advice,
)
from estimation.motion.decay_end import FreeWindow, centre, free_decay_end
from estimation.motion.decay_repeats import LOOK_FOR, analyse_decay_repeats, release_amplitude
from estimation.motion.decay_section import DecayResult, DecaySection
from estimation.motion.equivalent import damping_over_swings
from estimation.motion.estimation_result import EffectEstimate, EstimationResult
from estimation.motion.output_error_fit import MotionFit, fit_motion
from estimation.motion.record_bootstrap import DEFAULT_DRAWS, MIN_RECORDS, record_bootstrap
from estimation.motion.records import Record, Setup, known_terms_of, validate
from estimation.motion.term_search import KindSearch, SearchOutcome, search_terms
from estimation.motion.terms import DOFS, LIBRARY, units_of
from estimation.motion.well_determined import decay_combinations, inertia_and_stiffness
from estimation.report_numbers import Coefficient
from estimation.stats.acceptance_rules import DECAY_RULES
from estimation.stats.diagnostics import Whiteness, ljung_box, position_noise
from estimation.stats.misfit import WHITE_P, effective_sample_size, structured
from estimation.stats.repeatability import outlier_warnings

#: The model's own parameters, in the words of the screen's reason (``SEPARABLE``).
SETUP_PARAMETERS = "the model's own parameters (a constant force only moves a spring's equilibrium)"
MOVED_SIGMAS = 2.0  # a coefficient that moves more than this when a term is tried is fragile
#: Candidates tried on a decay after the base (damping, then restoring, then friction).
DECAY_CANDIDATES: tuple[str, ...] = (
    "quadratic_damping",
    "cubic_drag",
    "cubic_stiffness",
    "coulomb_friction",
    "constant_bias",
    "equilibrium_drift",
)


#: A sample within this many σ (noise) of the largest excursion is still at the release …
RELEASE_NOISE_SIGMAS = 3.0
#: … or within this many encoder steps of it (a one-count flicker of a held body).
RELEASE_QUANTA = 1.5


def release_of(record: Record) -> float:
    """Where a record's free motion starts: its first sample when driven; for a free decay
    the last sample still near the largest excursion from the final rest position
    (``envelope.centre``) before the motion first crosses that rest (a decay is released at
    its largest offset: the end of a push, or the end of a hold). Near: within
    max(RELEASE_NOISE_SIGMAS·σ, RELEASE_QUANTA encoder steps). The encoder step counts
    because a held body's encoder may flicker one count: that count is then the largest
    excursion, and within 3σ alone (σ below a count on a clean encoder) the release was put
    at the flicker, the held samples after it fitted as motion (seven, 0.35 s, of a 20 Hz
    record); a released body leaves the hold by many counts within a sample or two."""
    t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
    if record.drive is not None:
        return float(t[0])
    noise = position_noise([x], [t])
    off = x - centre(t, x, noise)
    peak = int(np.argmax(np.abs(off)))
    crossing = np.nonzero(np.sign(off[peak:]) != np.sign(off[peak]))[0]
    stop = peak + (int(crossing[0]) if crossing.size else off.size - peak)
    tolerance = max(RELEASE_NOISE_SIGMAS * noise, RELEASE_QUANTA * encoder_quantum(x))
    near = np.abs(off[peak:stop]) >= abs(off[peak]) - tolerance
    return float(t[peak + int(np.nonzero(near)[0][-1])])


def estimate_decay(
    t: np.ndarray,
    x: np.ndarray,
    dof: str,
    drive: float | np.ndarray | None = None,
    *,
    known_inertia: float = 0.0,
    inertia: float | None = None,
    stiffness: float | None = None,
    known_terms: Mapping[str, float] | None = None,
    min_inertia: float | None = None,
    t_release: float | None = None,
    t_end: float | None = None,
    candidates: Sequence[str] = DECAY_CANDIDATES,
    run_id: str = "decay",
) -> DecayResult:
    """Estimate one DOF's equation from one record (arrays t [s], x [m or rad], optional
    drive [N or N·m]). ``known_inertia``: the known part (body's dry inertia, rig);
    ``inertia``: the identified part when known; ``stiffness``: a known linear stiffness
    (N/m or N·m/rad); ``min_inertia``: the smallest identified inertia the body can have.
    ``t_release``/``t_end``: the free motion's window (default: ``release_of``, and for a
    free record where its envelope stops being a free decay, ``envelope.free_decay_end``).
    Raises ValueError for unusable input, ``EstimationFailed`` when the numerics fail."""
    record = Record(run_id, np.asarray(t, dtype=float), np.asarray(x, dtype=float), drive)
    return estimate_records(
        [record],
        dof,
        known_inertia=known_inertia,
        inertia=inertia,
        stiffness=stiffness,
        known_terms=known_terms,
        min_inertia=min_inertia,
        t_release={run_id: t_release} if t_release is not None else None,
        t_end={run_id: t_end} if t_end is not None else None,
        candidates=candidates,
    )


def _window(r: Record, start: float, end: float | None) -> Record:
    t = np.asarray(r.t, dtype=float)
    keep = (t >= start) & (t <= (np.inf if end is None else end))
    d = r.drive
    if d is not None and np.ndim(d) == 1:
        d = np.asarray(d, dtype=float)[keep]
    return replace(r, t=t[keep], x=np.asarray(r.x, dtype=float)[keep], drive=d)


@one_blas_thread
def estimate_records(
    records: Sequence[Record],
    dof: str,
    *,
    known_inertia: float = 0.0,
    inertia: float | None = None,
    stiffness: float | None = None,
    known_terms: Mapping[str, float] | None = None,
    min_inertia: float | None = None,
    t_release: Mapping[str, float] | None = None,
    t_end: Mapping[str, float] | None = None,
    candidates: Sequence[str] = DECAY_CANDIDATES,
    restoring_known: bool = False,
    n_bootstrap: int = DEFAULT_DRAWS,
    seed: int = 0,
    exclude_outliers: bool = False,
    subject: str | None = None,
    names: Mapping[str, str] | None = None,
) -> DecayResult:
    """``estimate_decay`` for several records of one DOF fitted jointly.
    ``subject``: what the records are of in the user's words, as the repeats' condition
    names it ("surge swing"; default "<dof> free decay"); ``names``: what the result calls
    the engine's coefficients where it differs (a pendulum's inertia is its added mass).
    Free records get the next release to run (``design.decay_information``).
    ``restoring_known``: each record carries its own restoring term among its known terms
    (a pendulum's gravity moment from its geometry), so none is identified or given here.
    ``n_bootstrap``: draws of the record-level bootstrap (``motion.record_bootstrap``, as a
    tow set's) when there are three records or more (``MIN_RECORDS``); 0: none. The free
    records' repeats are compared (``motion.decay_repeats``): a Chauvenet outlier is named in
    the warnings and kept in the fit, or left out with ``exclude_outliers``."""
    if n_bootstrap < 0:
        raise ValueError(f"n_bootstrap: got {n_bootstrap}, allowed: >= 0")
    known = dict(known_terms or {})
    base_terms: tuple[str, ...] = ("linear_damping",)
    if stiffness is not None:
        known["restoring_spring"] = float(stiffness)
    elif not restoring_known:
        base_terms = (*base_terms, "restoring_spring")
    setup = Setup(dof, float(known_inertia), inertia, known, base_terms, min_inertia)
    for r in records:
        validate([r], Setup(dof, known_inertia, inertia, known, base_terms))
    starts = {r.run_id: (t_release or {}).get(r.run_id, release_of(r)) for r in records}
    ends = {r.run_id: _end(r, starts[r.run_id], (t_end or {}).get(r.run_id)) for r in records}
    windowed = [_window(r, starts[r.run_id], ends[r.run_id].end) for r in records]
    subject = subject or f"{dof} free decay"
    repeats = analyse_decay_repeats(windowed, dof, subject, exclude_outliers)
    if repeats.excluded:
        windowed = [r for r in windowed if r.run_id not in repeats.excluded]
        starts = {r.run_id: starts[r.run_id] for r in windowed}
        ends = {r.run_id: ends[r.run_id] for r in windowed}
    validate(windowed, setup)
    base = fit_motion(windowed, setup)
    tried = [c for c in candidates if c not in known and c not in base.names]
    free = all(r.drive is None for r in windowed)
    outcome = search_terms(windowed, setup, base, tried, decay_search(free))
    final = outcome.final
    result = _result(setup, windowed, outcome, starts)
    alternatives = {
        other: (_coefficients(setup, alt), alt.bic - final.bic)
        for other, alt in outcome.alternatives.items()
    }
    first = windowed[0]
    equivalent = damping_over_swings(
        final,
        known_terms_of(first, setup),
        dof,
        result.natural_period_s,
        [r.t for r in windowed],
        weights=first.weights,
    )
    boot = (
        record_bootstrap(windowed, setup, final, n_bootstrap, seed)
        if n_bootstrap and len(windowed) >= MIN_RECORDS
        else None
    )
    planned, advice = _next_release(windowed, setup, final, names or {}) if free else ((), None)
    return replace(
        result,
        advice=(*result.advice, *([advice] if advice else [])),
        next_release=planned,
        warnings=(*result.warnings, *outlier_warnings(repeats, "record", LOOK_FOR)),
        repeats=repeats,
        bootstrap=boot,
        alternatives=alternatives,
        section=replace(result.section, window=ends),
        equivalent=equivalent,
        well_determined=decay_combinations(setup, first, final, equivalent),
        setup=setup,
        records=tuple(windowed),
        names=dict(names or {}),
    )


def _next_release(
    records: Sequence[Record],
    setup: Setup,
    final: MotionFit,
    names: Mapping[str, str],
) -> tuple[tuple[PlannedRelease, ...], str | None]:
    """Each coefficient's σ predicted after one more record released from each of
    ``AMPLITUDE_FACTORS`` × the largest release so far, and the sentence naming the best."""
    largest = max(release_amplitude(r) for r in records)
    if not largest > 0:
        return (), None
    unit = units_of(setup.dof, ())["position"]
    amplitudes = [f * largest for f in AMPLITUDE_FACTORS]
    planned = next_releases(records, setup, final, amplitudes, unit)
    chosen = best_release(planned, final.values)
    named = names.get(chosen[1], chosen[1]) if chosen else ""
    return planned, release_advice(planned, final.values, largest, named)


def _end(record: Record, start: float, given: float | None) -> FreeWindow:
    """Where ``record``'s fitted motion ends: ``given``, else a driven record's last sample,
    else where its free decay ends (``envelope.free_decay_end``)."""
    if given is not None:
        return FreeWindow(float(given), "given")
    t = np.asarray(record.t, dtype=float)
    if record.drive is not None:
        return FreeWindow(float(t[-1]), "end of the record")
    keep = t >= start
    x = np.asarray(record.x, dtype=float)[keep]
    return free_decay_end(t[keep], x, position_noise([x], [t[keep]]))


def _coefficients(setup: Setup, fit: MotionFit) -> dict[str, Coefficient]:
    """A fit's coefficients with σ (None: not identified) and units."""
    unit = "kg·m²" if DOFS[setup.dof] else "kg"
    return {
        n: Coefficient(
            float(v),
            None if not np.isfinite(s) else float(s),
            unit if n == "inertia" else LIBRARY[n].unit(setup.dof),
        )
        for n, v, s in zip(fit.names, fit.values, fit.std, strict=True)
    }


def decay_search(free: bool) -> KindSearch:
    """A decay's or pendulum's part of the one search (``motion.term_search``): its rules,
    pairs in the first round as every kind's, the words for its model's own parameters.
    ``free``: the records are free decays (no drive: the advice that separates terms)."""
    return KindSearch(DECAY_RULES, pairs=True, own_parameters=SETUP_PARAMETERS, free=free)


def _result(setup, records, outcome: SearchOutcome, starts) -> DecayResult:
    base, final = outcome.base, outcome.final
    rotational = DOFS[setup.dof]
    units = {
        n: LIBRARY[n].unit(setup.dof) for n in (*final.names, *setup.known_terms) if n != "inertia"
    }
    units["inertia"] = "kg·m²" if rotational else "kg"
    coefficients = _coefficients(setup, final)
    known = {n: Coefficient(float(v), 0.0, units[n]) for n, v in setup.known_terms.items()}
    if setup.inertia is not None:
        known["inertia"] = Coefficient(float(setup.inertia), 0.0, units["inertia"])
    labels: dict[str, str] = {}
    if setup.known_inertia > 0:  # the document says the inertia above is the rest of it
        known["known_inertia"] = Coefficient(float(setup.known_inertia), 0.0, units["inertia"])
        added = "added inertia" if rotational else "added mass"
        labels["inertia"] = f"{added} (body's own {setup.known_inertia:.6g} given)"
    white = ljung_box(final.residuals)
    moved = _moved(final, [base, *outcome.rejected])
    noise = position_noise(final.residuals, [r.t for r in records])
    ratio = final.rmse / noise if noise > 0 else float("inf")
    misfit = structured(white.p_value, ratio, effective_sample_size(final.residuals))
    fragile = white.p_value < WHITE_P and moved
    biased = fragile or misfit
    free = all(r.drive is None for r in records)
    # one sentence on the residual, whichever rules flag it
    warnings = _warnings(setup, final, white, fragile and not misfit, free)
    if misfit:
        moved_too = (
            f"; the coefficients move by more than {MOVED_SIGMAS:g}σ when a term is added or "
            "left out"
            if fragile
            else ""
        )
        warnings.append(
            f"the residual is {ratio:.1f}× the noise floor the fit implies (Ljung–Box p = "
            f"{white.p_value:.2g}){moved_too}: the record holds motion no kept term explains, "
            "so the coefficients may be biased by it"
        )
    total_m, k = inertia_and_stiffness(setup, records[0], final)
    period = 2 * np.pi * np.sqrt(total_m / k) if k and k > 0 and total_m > 0 else None
    ids = tuple(r.run_id for r in records)
    return EstimationResult(
        axis=setup.dof,
        method="output-error",
        runs=ids,
        coefficients=coefficients,
        coefficients_before=_coefficients(setup, base),
        units=units_of(setup.dof, [n for n in (*coefficients, *known) if n in LIBRARY]),
        effects=tuple(
            EffectEstimate(e, final.value(e), final.sigma(e), coefficients[e].unit)
            for e in final.effects
        ),
        known=known,
        labels=labels,
        not_identified=final.not_identified,
        rmse_before=base.rmse,
        rmse_after=final.rmse,
        rmse_per_run_before=dict(zip(ids, base.rmse_per_run(), strict=True)),
        rmse_per_run_after=dict(zip(ids, final.rmse_per_run(), strict=True)),
        noise=noise,
        whiteness_before=ljung_box(base.residuals),
        whiteness_after=white,
        rules=DECAY_RULES,
        possibly_biased=biased,
        natural_period_s=period,
        warnings=tuple(warnings),
        steps=outcome.steps,
        cv_before=outcome.cv_base,
        cv_after=outcome.cv_final,
        advice=outcome.advice,
        ambiguous=outcome.ambiguous,
        section=DecaySection(
            equilibrium={
                r.run_id: float(e) for r, e in zip(records, final.equilibrium, strict=True)
            },
            release_time_s=dict(starts),
        ),
        fit_before=base,
        fit_after=final,
    )


def _moved(final: MotionFit, others: Sequence[MotionFit]) -> bool:
    """Whether a coefficient of ``final`` differs by more than MOVED_SIGMAS σ in another
    fit of nested structure (the base, or a candidate tried against it)."""
    for other in others:
        for n, v, s in zip(final.names, final.values, final.std, strict=True):
            moved = n in other.names and abs(other.value(n) - v) > MOVED_SIGMAS * s
            if np.isfinite(s) and s > 0 and moved:
                return True
    return False


def _at_bound_sentence(name: str, value: float) -> str:
    """A term held at its bound, with the causes a free record can have: a damping held at
    0 means the records lose less energy than any positive value takes out."""
    term = LIBRARY[name]
    if term.role == "force" and term.v_power is not None:
        cause = (
            "the records lose less energy than any positive value of it takes out: energy "
            "put in by something the model lacks (a carriage, a wave or a mooring still "
            "moving the body, a zero that drifts), or another kept term taking its part"
        )
    else:
        cause = f"the records want a value beyond it ({term.physical}); another kept term may "
        cause += "take its part, or a force the model lacks acts"
    return f"{name} sits at its bound {value:.3g} (held there, not identified): {cause}"


def _warnings(
    setup: Setup, final: MotionFit, white: Whiteness, biased: bool, free: bool
) -> list[str]:
    out = []
    for n in final.not_identified:
        hint = LIBRARY[n].separation(free) if n in LIBRARY else "a forced run or a known stiffness"
        out.append(
            f"{n} is not identified by these records: no σ is given; add a record that "
            f"excites it ({hint})"
        )
    for n in final.at_bound:
        if n in LIBRARY:
            out.append(_at_bound_sentence(n, final.value(n)))
    for n in final.effects:
        value, std = final.value(n), final.sigma(n)
        if np.isfinite(std) and abs(value) < 2 * std:
            out.append(
                f"{n} = {value:.3g} ± {std:.2g} {LIBRARY[n].unit(setup.dof)} was kept on the "
                "information criterion, which takes the residual as white, but lies within "
                "2σ of zero by the σ that counts its correlation: it may be the residual's "
                f"structure rather than this term ({LIBRARY[n].separation(free)})"
            )
    if "inertia" in final.names and setup.min_inertia is not None:
        value = final.value("inertia")
        if value < setup.min_inertia:
            out.append(
                f"inertia {value:.4g} is below what the body has ({setup.min_inertia:.4g}):"
                " not physical; the record may start after the release or miss its "
                "acceleration"
            )
    if biased:
        out.append(
            f"the residual is not white (Ljung–Box p = {white.p_value:.2g}) and the "
            f"coefficients move by more than {MOVED_SIGMAS:g}σ when a term is added or left "
            "out: they may be biased by structure no library term explains"
        )
    return out
