"""The next test: the run that most reduces what stands between the estimate and its target.

State of one axis (:class:`AxisState`): the latest fit (values, σ, correlations, ambiguous
groups, position RMSE σ_x), its uncertainty budget (``estimation.uncertainty.budget``) and the
tests recorded. Target: U/|θ| ≤ ``relative`` for M, K_L, K_Q — U the expanded uncertainty a
lab signs (GUM, 95 %), not the fit's 2σ — every σ finite, and no ambiguous group (two effect
sets explaining the runs alike). U = k·√(u_A² + u_B²): the Type A part (the fit σ and the
sources that shrink with it) scales with the fit σ a run is predicted to leave,
u_A' = u_A·σ'/σ; the Type B part (the declared tolerances) is held where the budget put it.
A Type B contribution c·u moves with the design only through its sensitivity, which the
planner does not model, so when Type B alone is above the target (``floor``) no run the
planner can choose brings U under it: the campaign stops as out of reach, naming the
coefficient and the tolerance that dominates it (on the BENBAM rig file the ±5 g of each
hung weight gives K_L 3.70 % of surge after the 8 seed tows and after 12 campaign tows, and
28 % of yaw: a weight error is a constant force that runs at other speeds read as linear
damping). Without a budget U is 2σ.

Criterion. The terms a run's information is judged on (``planned_terms``) are M, K_L, K_Q,
the modelled effects (F_c, b) the fit found, and those it suspects: in an ambiguous group,
or friction and bias while every run went one way; a term neither found nor suspected is
held at zero, so a clean axis is planned on its base model. The information of the
recorded runs, I₀ = Σ Jᵣᵀ·Jᵣ / σ_x² (``estimation.design.information``) over those terms,
is scaled to the fit by k = median_i(σ_fit,i² / (I_fit⁻¹)_ii) with I_fit over the terms the
fit estimated (``fitted_terms``): its σ are conditional on the terms it left out, so
calibrating them against a model with more terms free made k swing by 10⁵ between runs
and the predictions wildly optimistic. For a candidate c, C_c = k·(I₀ + I_c)⁻¹ predicts the
covariance after it. Then
- friction and bias ambiguous → of the candidates predicted to bring their |ρ| under 0.9,
  the one with the most progress on the target ratio per tank minute (below); if none
  does, the one bringing |ρ| lowest (a reverse run decorrelates them);
- otherwise → the most progress on the worst target ratio max_i U_i(C)/|θ_i|/target per
  tank minute (run + reset), a minimax (A-type) design on the target coefficients.
Progress is ln(before) − ln(after), each capped below at 1 (``_progress``): U falls like
1/√(information), and the absolute reduction bought the shortest run whenever the ratio
was far above 1 — on the dry-friction scenario a fast tow, where only a slow one separates
F_c from K_L.
Each load is offered to the end of travel and stopped short (``RigEnvelope.run_lengths``):
a run's length is judged like its load, by progress per tank minute, and a stopped run's
information is that of the full run's beginning; most of what a tow or spin teaches is in
its rise and first steady stretch, while the reset is paid either way.
While every run of an axis went one way, only the other way's candidates are considered
(friction and a bias are one constant then; the target requires them told apart).
Stopping rule (``decide``): the target is met on every axis (U/|θ| ≤ target, every σ
finite, no ambiguous group left), it is out of reach (Type B alone above it, judged once no
fit is ambiguous nor one-way), or the next run does not fit the budget (runs, tank minutes).

A released axis (a pendulum: ``ReleaseEnvelope``) is planned on the same target, U, progress
and stopping rule; only the prediction differs. Its state carries, per release amplitude the
rig allows, each coefficient's σ predicted after one more record released from it
(``estimation.design.release_outlook``, from ``decay_information``: the one engine's fit of
the stored records) and the run's predicted duration; the choice is the most progress on
the worst target ratio per tank minute (``_choose_release``). Its target coefficients are
those the fit carries of M (the added mass), K_L and K_Q (``AxisState.targets``). Its
opening, with no record yet: half the largest release the rig allows (``opening``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TypedDict

import numpy as np

from estimation.design.information import PARAMETERS, predict, predict_lengths
from estimation.design.planning_envelope import Candidate, ReleaseEnvelope, RigEnvelope
from estimation.uncertainty.budget import Budget

BASE = PARAMETERS[:3]
FRICTION_PAIR = frozenset({"coulomb_friction", "constant_bias"})
SEPARABILITY_LIMIT = 0.95
#: A pair counts as separated by a candidate when its predicted |ρ| is below this: a margin
#: under the estimator's limit, since the prediction assumes the current model is right.
SEPARATED = 0.9
#: The opening of an axis with no fit yet: the two loads a quadratic law needs, as shares
#: of the largest weight load (K_L and K_Q separate only with two clearly different speeds).
OPENING_SHARES = (1.0, 0.35)
#: The opening of a released axis with no record: this share of the largest release the rig
#: allows. No fit yet means no information to compare releases on; one record suffices (a
#: decay sweeps its amplitude from the release down to the stop, so it separates K_L from
#: K_Q where a tow needs two loads); the largest release leans most on what the fit must
#: get right at large angles (sin φ, drag that grows with speed, the latch's tolerance) and
#: the smallest decays to the stop amplitude within a few swings at the worst signal to
#: noise; the middle shows both dampings, and the criterion moves up or down from its fit.
RELEASE_OPENING_SHARE = 0.5


@dataclass(frozen=True)
class ReleaseOutlook:
    """One more release from ``amplitude`` (m or rad): each coefficient's fit σ predicted
    after it (``std_after``, the fit's names) and the run's predicted duration (s)."""

    amplitude: float
    std_after: Mapping[str, float]
    duration_s: float


@dataclass(frozen=True)
class AxisState:
    """The latest fit of one axis and the tests behind it."""

    axis: str
    values: Mapping[str, float]
    std: Mapping[str, float]
    correlation: Mapping[tuple[str, str], float]
    ambiguous: tuple[tuple[str, ...], ...]
    rmse: float
    recorded: tuple[Candidate, ...]
    #: Per coefficient, from the budget: u_A/σ (the Type A sources over the fit σ, ≥ 1),
    #: u_B (the declared tolerances, the coefficient's unit) and the coverage factor k.
    #: Absent (no budget): 1, 0 and 2, so U = 2σ.
    type_a_scale: Mapping[str, float] = field(default_factory=dict)
    type_b: Mapping[str, float] = field(default_factory=dict)
    coverage: Mapping[str, float] = field(default_factory=dict)
    #: The Type B source with the largest contribution, per coefficient ("" when none).
    type_b_source: Mapping[str, str] = field(default_factory=dict)
    #: The coefficients the target is judged on (a released axis: those its fit carries).
    targets: tuple[str, ...] = BASE
    #: A released axis: each release the rig allows, as predicted from this fit.
    releases: tuple[ReleaseOutlook, ...] = ()
    #: The result's name of an engine coefficient where it differs (a pendulum's inertia is
    #: its added mass): the trail and its why name each coefficient as the result does.
    names: Mapping[str, str] = field(default_factory=dict)

    def name(self, coefficient: str) -> str:
        """``coefficient`` (an engine name) as the axis's result names it."""
        return self.names.get(coefficient, coefficient)

    def expanded(self, name: str, std: float) -> float:
        """U of ``name`` were its fit σ ``std``: k·√((u_A/σ·std)² + u_B²)."""
        a, b = self.type_a_scale.get(name, 1.0), self.type_b.get(name, 0.0)
        return self.coverage.get(name, 2.0) * float(np.hypot(a * std, b))

    def ratios(self, relative: float) -> dict[str, float]:
        """U/|θ| over the target, per target coefficient (NaN σ → inf)."""
        return self.ratios_at(relative, self.std)

    def ratios_at(self, relative: float, std: Mapping[str, float]) -> dict[str, float]:
        """U/|θ| over the target per target coefficient were the fit's σ ``std``."""
        out = {}
        for n in self.targets:
            v, s = self.values.get(n, np.nan), std.get(n, np.nan)
            ok = np.isfinite(s) and np.isfinite(v) and v != 0
            out[n] = float(self.expanded(n, s) / abs(v) / relative) if ok else float("inf")
        return out

    def floor(self, relative: float) -> dict[str, float]:
        """k·u_B/|θ| over the target, per target coefficient: U with the Type A part gone
        (above 1: the declared tolerances alone miss the target)."""
        out = {}
        for n in self.targets:
            v = self.values.get(n, np.nan)
            ok = np.isfinite(v) and v != 0
            out[n] = float(self.expanded(n, 0.0) / abs(v) / relative) if ok else 0.0
        return out

    def unresolved(self) -> list[str]:
        """What keeps the fit from being final besides σ: the estimator's ambiguities (two
        models explain the runs alike). A strong correlation between fitted coefficients is
        not listed: the marginal σ the target is judged on already carries it."""
        return [f"{' vs '.join(g)} ambiguous" for g in self.ambiguous]

    def correlated(self) -> list[str]:
        """Fitted pairs with |ρ| > 0.95 (shown, not blocking: see ``unresolved``)."""
        return [
            f"{a} and {b} correlated (ρ = {r:.3f})"
            for (a, b), r in self.correlation.items()
            if abs(r) > SEPARABILITY_LIMIT
        ]


@dataclass(frozen=True)
class Choice:
    """A chosen test, why, and the predicted worst target ratio before → after."""

    test: Candidate
    why: str
    predicted_before: float
    predicted_after: float
    minutes: float


@dataclass(frozen=True)
class Decision:
    """Stop (``stop`` says why: "target" | "budget: …") or run ``choice``."""

    stop: str | None
    choice: Choice | None = None
    status: dict[str, dict] = field(default_factory=dict)


def state_from_result(
    result: object, recorded: Sequence[Candidate], budget: Budget | None = None
) -> AxisState:
    """The planner's view of an ``estimation.axis.tow_section.TowResult`` and its
    uncertainty ``budget`` (None: none, U = 2σ)."""
    r = result  # duck-typed: a TowResult
    values = {n: e.value for n, e in r.coefficients.items()}  # type: ignore[attr-defined]
    std = {n: e.std for n, e in r.coefficients.items()}  # type: ignore[attr-defined]
    for e in r.effects:  # type: ignore[attr-defined]
        values[e.name], std[e.name] = e.value, e.std
    fit = r.fit_after  # type: ignore[attr-defined]
    pairs = correlation_pairs(fit.names, fit.correlation)
    return AxisState(
        axis=r.axis,  # type: ignore[attr-defined]
        values=values,
        std=std,
        correlation=pairs,
        ambiguous=tuple(tuple(g) for g in r.ambiguous),  # type: ignore[attr-defined]
        rmse=float(r.fit_after.rmse),  # type: ignore[attr-defined]
        recorded=tuple(recorded),
        **budget_terms(budget, std),
    )


def correlation_pairs(
    names: Sequence[str], correlation: np.ndarray
) -> dict[tuple[str, str], float]:
    """Each pair (a, b) of ``names``, a before b, with its finite correlation."""
    corr = np.asarray(correlation)
    return {
        (a, b): float(corr[i, j])
        for i, a in enumerate(names)
        for j, b in enumerate(names)
        if i < j and np.isfinite(corr[i, j])
    }


class BudgetTerms(TypedDict):
    """``AxisState``'s fields drawn from a budget."""

    type_a_scale: dict[str, float]
    type_b: dict[str, float]
    coverage: dict[str, float]
    type_b_source: dict[str, str]


def budget_terms(
    budget: Budget | None, std: Mapping[str, float], named: Mapping[str, str] | None = None
) -> BudgetTerms:
    """``AxisState``'s budget fields (``type_a_scale``, ``type_b``, ``coverage``,
    ``type_b_source``) from ``budget`` for the fit σ ``std``; ``named``: the fit's name of
    each coefficient the budget names otherwise (a pendulum's added mass is the inertia)."""
    scale: dict[str, float] = {}
    type_b: dict[str, float] = {}
    coverage: dict[str, float] = {}
    source: dict[str, str] = {}
    back = {v: k for k, v in (named or {}).items()}
    for key, b in (budget.coefficients if budget is not None else {}).items():
        n = back.get(key, key)
        used = [row for row in b.rows if row.combined]
        u_a = float(np.sqrt(sum(row.contribution**2 for row in used if row.kind == "A")))
        rows_b = [row for row in used if row.kind == "B"]
        type_b[n] = float(np.sqrt(sum(row.contribution**2 for row in rows_b)))
        source[n] = max(rows_b, key=lambda row: row.contribution).source if rows_b else ""
        sigma = std.get(n, np.nan)
        scale[n] = max(u_a / sigma, 1.0) if np.isfinite(sigma) and sigma > 0 else 1.0
        coverage[n] = b.k if np.isfinite(b.k) else 2.0
    return {"type_a_scale": scale, "type_b": type_b, "coverage": coverage, "type_b_source": source}


def _theta(state: AxisState) -> np.ndarray:
    return np.array([float(state.values.get(n, 0.0)) for n in PARAMETERS])


def fitted_terms(state: AxisState) -> tuple[str, ...]:
    """The planner's parameters the fit estimated: the base and the modelled effects it
    found (``FRICTION_PAIR``); its σ are conditional on every term it left out."""
    return (*BASE, *(n for n in PARAMETERS[3:] if n in state.values))


def planned_terms(state: AxisState) -> tuple[str, ...]:
    """The parameters a candidate's information is judged on: the fitted ones and the
    modelled effects the runs suspect — one in an ambiguous group (the estimator could not
    rule it out), or friction and bias while every run went one way (the runs cannot tell
    them apart nor from zero). A term neither found nor suspected is held at zero: a clean
    axis is planned on its base model, so its runs are not bought to pin a term it lacks."""
    suspected = {n for group in state.ambiguous for n in group}
    if len({np.sign(t.load) for t in state.recorded}) == 1:
        suspected |= FRICTION_PAIR
    fitted = fitted_terms(state)
    return (*fitted, *(n for n in PARAMETERS[3:] if n in suspected and n not in fitted))


def _information(
    state: AxisState, env: RigEnvelope, tests: Sequence[Candidate], terms: Sequence[str]
) -> np.ndarray:
    """Σ Jᵀ·J/σ_x² of ``tests`` over ``terms`` (the other parameters held at their values)."""
    axis = env.driven(state.axis)
    assert axis is not None
    theta = _theta(state)
    info = sum((predict(theta, axis, t, env.g).information for t in tests), start=np.zeros((5, 5)))
    return _restricted(info, terms) / max(state.rmse, 1e-9) ** 2


def _restricted(info: np.ndarray, terms: Sequence[str]) -> np.ndarray:
    """The rows and columns of ``terms`` of a 5×5 information over ``PARAMETERS``."""
    index = [PARAMETERS.index(n) for n in terms]
    return info[np.ix_(index, index)]


def _prior(env: RigEnvelope, axis: str, terms: Sequence[str]) -> np.ndarray:
    """A weak prior on friction and bias (σ = the largest load) among ``terms``: keeps I
    invertible when every run went one way, without deciding anything."""
    load = env.driven(axis).max_load  # type: ignore[union-attr]
    return np.diag([0.0 if n in BASE else 1 / load**2 for n in terms])


def _covariance(info: np.ndarray) -> np.ndarray:
    return np.linalg.pinv(info + 1e-12 * np.eye(len(info)) * np.trace(info))


def _fit_scale(state: AxisState, model_cov: np.ndarray) -> float:
    """k = median σ_fit²/σ_model² over the base coefficients (1 when none is finite)."""
    ratios = [
        state.std[n] ** 2 / model_cov[i, i]
        for i, n in enumerate(BASE)
        if np.isfinite(state.std.get(n, np.nan)) and model_cov[i, i] > 0
    ]
    return float(np.median(ratios)) if ratios else 1.0


def _worst(cov: np.ndarray, state: AxisState, relative: float) -> float:
    """The worst U/|θ| over the target were the fit's covariance ``cov`` (base first)."""
    sig = np.sqrt(np.clip(np.diag(cov)[:3], 0, None))
    theta = np.maximum(np.abs(_theta(state)[:3]), 1e-12)
    ratios = zip(BASE, sig, theta, strict=True)
    return max(state.expanded(n, float(s)) / t / relative for n, s, t in ratios)


def _progress(before: float, after: float) -> float:
    """What a run buys on the worst target ratio: ln(before) − ln(after), both capped
    below at 1 (the target: a run that goes below it buys nothing more). U falls like
    1/√(information), so the log is what each run's information divides; the absolute
    reduction favoured the shortest run whenever the ratio was far above 1 (every
    candidate then removes nearly all of it), which ran a fast reverse tow before the
    slow one that separates dry friction from K_L."""
    return float(np.log(max(before, 1.0)) - np.log(max(after, 1.0)))


def _rho(cov: np.ndarray, terms: Sequence[str], a: str, b: str) -> float:
    i, j = terms.index(a), terms.index(b)
    return float(abs(cov[i, j]) / np.sqrt(max(cov[i, i] * cov[j, j], 1e-300)))


def _pair_to_separate(state: AxisState) -> tuple[str, str] | None:
    for group in state.ambiguous:
        if set(group) >= FRICTION_PAIR:
            return ("coulomb_friction", "constant_bias")
    return None


def _other_way(state: AxisState, env: RigEnvelope) -> float | None:
    """The sign every recorded run lacks when all went one way and the rig can reverse:
    such a set cannot tell dry friction from a bias (−F_c·sign(v) and b are one constant),
    which the target requires resolved, so the next run goes the other way."""
    axis = env.driven(state.axis)
    signs = {np.sign(t.load) for t in state.recorded}
    if axis is None or axis.reverse_travel is None or len(signs) != 1:
        return None
    return -float(signs.pop())


def _judged(state: AxisState, relative: float) -> AxisState:
    """The state a run's progress is judged on: ``state``, or without its Type B when that
    alone is above the target. The campaign then measures only to settle its models
    (``_out_of_reach``), and a run changes only the Type A part: judged on U with the floor
    in it, every candidate's progress is nearly nil and the shortest won (a fast reverse
    spin that left yaw K_L 8.7 % off on the dry-friction scenario)."""
    if max(state.floor(relative).values(), default=0.0) <= 1.0:
        return state
    return replace(state, type_b={})


def choose(state: AxisState, env: RigEnvelope, relative: float) -> Choice | None:
    """The best next test on ``state.axis`` (module docstring); None when the rig offers
    none that moves the body within its rate limit."""
    released = env.released(state.axis)
    if released is not None:
        return _choose_release(state, released, env.reset_s, relative)
    axis_env = env.driven(state.axis)
    if axis_env is None:
        return None
    theta = _theta(state)
    fitted, terms = list(fitted_terms(state)), list(planned_terms(state))
    fitted_info = _information(state, env, state.recorded, fitted)
    k = _fit_scale(state, _covariance(fitted_info + _prior(env, state.axis, fitted)))
    base_info = _information(state, env, state.recorded, terms) + _prior(env, state.axis, terms)
    before = _worst(k * _covariance(base_info), state, relative)
    judged = _judged(state, relative)
    judged_before = _worst(k * _covariance(base_info), judged, relative)
    pair = _pair_to_separate(state)
    other_way = _other_way(state, env)
    scored = []
    for load in env.candidates(state.axis):
        if other_way is not None and np.sign(load.load) != other_way:
            continue
        lengths = env.run_lengths(load)  # one integration for every length of a load
        for c, p in zip(lengths, predict_lengths(theta, axis_env, lengths, env.g), strict=True):
            if not p.moves or p.peak_rate > axis_env.max_rate:
                continue
            minutes = (p.duration_s + env.reset_s) / 60
            added = _restricted(p.information, terms) / max(state.rmse, 1e-9) ** 2
            cov = k * _covariance(base_info + added)
            after = _worst(cov, state, relative)
            gain = -_progress(judged_before, _worst(cov, judged, relative)) / minutes
            if pair is not None:  # separated (with margin): the most informative; else lowest |ρ|
                rho = _rho(cov, terms, *pair)
                key = (0.0, gain) if rho < SEPARATED else (rho, minutes)
            else:
                key = (gain, minutes)
            scored.append((key, c, after, minutes, cov))
    if not scored:
        return None
    key, best, after, minutes, cov = min(scored, key=lambda s: s[0])
    if pair is not None:
        why = (
            f"{pair[0]} and {pair[1]} are not yet separated: of {len(scored)} tests the rig "
            f"can run, this one is predicted to bring |ρ| under {SEPARATED} ("
            f"{_rho(cov, terms, *pair):.2f}) with the largest reduction of the worst target "
            f"ratio's log per tank minute ({before:.2f} → {after:.2f}), or else to bring |ρ| "
            "lowest"
        )
    else:
        way = (
            "every run so far went one way (friction and a bias look alike): of the "
            if other_way is not None
            else "of the "
        )
        why = (
            f"the worst target ratio is {before:.2f} (1 = target met); {way}{len(scored)} "
            f"tests the rig can run{' the other way' if other_way is not None else ''}, this "
            f"one is predicted to bring it to {after:.2f}, the largest reduction of its log "
            "per tank minute"
        )
    return Choice(best, why, before, after, minutes)


def _choose_release(
    state: AxisState, env: ReleaseEnvelope, reset_s: float, relative: float
) -> Choice | None:
    """The release (``state.releases``, within ``env``) with the most progress on the worst
    target ratio per tank minute (run + ``reset_s``): ``_progress`` on ``_judged``, as a
    driven axis's; None when the state predicts no release the rig allows."""
    judged = _judged(state, relative)
    before = max(state.ratios(relative).values(), default=float("inf"))
    judged_before = max(judged.ratios(relative).values(), default=float("inf"))
    if not state.releases:  # a σ not known: nothing to predict from
        unknown = [
            state.name(n) for n in state.targets if not np.isfinite(state.std.get(n, np.nan))
        ]
        why = (
            f"σ of {', '.join(unknown) or 'a coefficient'} not known, so no release can be "
            "predicted: the largest the rig allows, where every damping shows most"
        )
        test = Candidate(state.axis, env.max_amplitude, "release", env)
        return Choice(test, why, before, float("inf"), (env.max_run_s + reset_s) / 60)
    scored = []
    for r in state.releases:
        if not 0 < r.amplitude <= env.max_amplitude:
            continue
        minutes = (r.duration_s + reset_s) / 60
        after = max(state.ratios_at(relative, r.std_after).values(), default=float("inf"))
        judged_after = max(judged.ratios_at(relative, r.std_after).values(), default=float("inf"))
        gain = -_progress(judged_before, judged_after) / minutes
        scored.append(((gain, minutes), r, after, minutes))
    if not scored:
        return None
    _, best, after, minutes = min(scored, key=lambda s: s[0])
    ratios = state.ratios(relative)
    worst = max(ratios, key=ratios.__getitem__)
    why = (
        f"the worst target ratio is {before:.2f} ({state.name(worst)}; 1 = target met); of the "
        f"{len(scored)} releases the rig allows, one from {best.amplitude:.3g} {env.unit} is "
        f"predicted to bring it to {after:.2f} in {minutes:.1f} tank min, the largest "
        "reduction of its log per tank minute"
    )
    test = Candidate(state.axis, best.amplitude, "release", env)
    return Choice(test, why, before, after, minutes)


def opening(env: RigEnvelope, axis: str, done: Sequence[Candidate]) -> Candidate | None:
    """The next opening test of an axis without a fit (``OPENING_SHARES``; a released axis:
    ``RELEASE_OPENING_SHARE`` of its largest release), None when done."""
    released = env.released(axis)
    if released is not None:
        test = Candidate(axis, RELEASE_OPENING_SHARE * released.max_amplitude, "release", released)
        return None if test in done else test
    axis_env = env.driven(axis)
    if axis_env is None:
        return None
    for share in OPENING_SHARES:
        test = Candidate(axis, share * axis_env.max_load)  # type: ignore[arg-type]
        if test not in done:
            return test
    return None


def axis_status(state: AxisState | None, relative: float) -> dict:
    """``{"ratios", "unresolved", "reached"}`` of one axis (no fit: not reached); the
    ratios are U/|θ| over the target."""
    if state is None:
        return {"ratios": {}, "unresolved": ["no fit yet"], "reached": False}
    ratios = state.ratios(relative)
    unresolved = state.unresolved()
    reached = all(r <= 1.0 for r in ratios.values()) and not unresolved
    return {"ratios": ratios, "unresolved": unresolved, "reached": reached}


def _unsettled(state: AxisState, env: RigEnvelope) -> bool:
    """The axis's models are not yet told apart: its fit is ambiguous, or every run went one
    way on a rig that can reverse (friction and a bias are one constant then)."""
    return bool(state.ambiguous) or _other_way(state, env) is not None


def _out_of_reach(
    states: Mapping[str, AxisState | None], env: RigEnvelope, relative: float
) -> str | None:
    """Why the target cannot be met (Type B alone above it on some coefficient), or None.
    Not while a fit is ambiguous or an axis's runs all went one way on a rig that can
    reverse (friction and a bias are one constant then): its coefficients, and the floor
    computed at them, may be far off — on the dry-friction scenario surge K_L was 59 % off
    and yaw's inertia 0.96 % (U 0.68 %) when the floor first passed the target — so the
    campaign measures on until its models are told apart, then stops with coefficients
    worth reporting."""
    if any(s is not None and _unsettled(s, env) for s in states.values()):
        return None
    for axis, state in states.items():
        if state is None:
            continue
        floor = state.floor(relative)
        worst = max(floor, key=floor.__getitem__, default=None)
        if worst is not None and floor[worst] > 1.0:
            return (
                f"target out of reach: on {axis} the declared tolerances alone give "
                f"{state.name(worst)} "
                f"U = {floor[worst] * relative * 100:.2g} % of its value, above the "
                f"{relative * 100:g} % target, and more runs do not shrink them (dominant: "
                f"{state.type_b_source.get(worst) or 'Type B'}); declare that tolerance "
                "tighter if it can be, or set a target above it"
            )
    return None


def _urgency(state: AxisState, env: RigEnvelope, relative: float) -> tuple[bool, bool, float]:
    """How the axis the next test goes to is chosen (the largest first): an axis whose
    models are not yet told apart (ambiguous, or every run one way on a rig that can
    reverse: ``_out_of_reach`` waits for it), then one with anything unresolved, then the
    worst target ratio on the part a run can shrink (``_judged``). Ranked on U with a Type B
    floor above the target in it, an axis out of reach won every choice: on the clean
    scenario with the rig file's tolerances, yaw (K_L U 32.5 %) took ten spins that moved U
    by 0.01 % while surge, one-way, held the stop off until the budget ran out."""
    judged = _judged(state, relative).ratios(relative)
    return _unsettled(state, env), bool(state.unresolved()), max(judged.values(), default=0.0)


def decide(
    states: Mapping[str, AxisState | None],
    env: RigEnvelope,
    relative: float,
    *,
    runs_used: int,
    minutes_used: float,
    max_runs: int,
    max_minutes: float,
    done: Mapping[str, Sequence[Candidate]],
) -> Decision:
    """Stop at the target or the budget, else the next test: an opening run of an axis
    without a fit, else the chosen test of the most urgent axis (``_urgency``)."""
    status = {a: axis_status(s, relative) for a, s in states.items()}
    if all(s["reached"] for s in status.values()):
        return Decision("target", status=status)
    if out_of_reach := _out_of_reach(states, env, relative):
        return Decision(out_of_reach, status=status)
    if runs_used >= max_runs:
        return Decision(f"budget: {runs_used} of {max_runs} runs used", status=status)
    pending = [a for a, s in status.items() if not s["reached"]]
    choice: Choice | None = None
    for axis in pending:
        if states[axis] is None:
            test = opening(env, axis, done.get(axis, ()))
            if test is not None:
                why = (
                    "opening run of the axis: no record to predict from; half the largest "
                    "release the rig allows shows both dampings in one decay"
                    if test.release is not None
                    else "opening run of the axis: a fit needs two clearly different loads"
                )
                choice = Choice(test, why, float("inf"), float("inf"), 0.0)  # duration unknown
                break
    if choice is None:
        worst = max(
            (a for a in pending if states[a] is not None),
            key=lambda a: _urgency(states[a], env, relative),  # type: ignore[arg-type]
            default=None,
        )
        if worst is not None:
            choice = choose(states[worst], env, relative)  # type: ignore[arg-type]
    if choice is None:
        return Decision("budget: the rig offers no test that would help", status=status)
    if minutes_used + choice.minutes > max_minutes:
        return Decision(
            f"budget: the next run ({choice.minutes:.1f} min) would pass {max_minutes:g} "
            f"tank minutes ({minutes_used:.1f} used)",
            choice,
            status,
        )
    return Decision(None, choice, status)
