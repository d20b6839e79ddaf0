"""Output-error fit of the pendulum's nonlinear moment balance, and the search for effects.

Fits α, β (and any effects) jointly over runs, with each run's state (φ₀, φ̇₀) at its first
sample after release and its encoder zero offset as nuisance parameters (the fitted
initial state also absorbs an error in the release instant):

    (J_known + α·l²)·φ̈ = −k·sin φ − (β·l² + b)·φ̇ [− γ·l³·|φ̇|·φ̇] [− τ_c·sgn φ̇]
    φ_measured = φ + offset

σ never below σ̂²(JᵀJ)⁻¹ (σ̂² = SSE/(n − p)), larger when the residual is correlated within
a run (``estimation.stats.identify``; σ NaN: not identified). An effect is kept by the
rules every record's search uses (``estimation.stats.selection.term_verdict``): identified,
off its physical bound, ΔBIC < −10 and material against the noise floor (the residual it
explains at least the position noise σ). The pendulum's former rules — its largest torque
≥ 0.5 % of the restoring torque, and "Ljung–Box Q must drop" — are gone: both reject true
damping on a lightly damped body (docs/estimation.md, *Why the old rules failed*).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from estimation.axis.search import AMBIGUITY_BIC, SearchStep
from estimation.pendulum.decay import Decay
from estimation.pendulum.sim import simulate, step_size
from estimation.stats.diagnostics import ljung_box, position_noise
from estimation.stats.fit import FitStatistics, solution_statistics
from estimation.stats.selection import (
    BIC_THRESHOLD,
    forward_selection,
    select_round,
    term_verdict,
)

BASE_NAMES: tuple[str, ...] = ("added_mass", "linear_damping")


@dataclass(frozen=True)
class PendulumEffect:
    """A candidate effect of the pendulum: formula, unit, residual signature, experiment."""

    name: str
    formula: str
    unit: str
    signature: str
    separated_by: str
    lower: float = 0.0


PENDULUM_EFFECTS: dict[str, PendulumEffect] = {
    e.name: e
    for e in (
        PendulumEffect(
            "pivot_dry_friction",
            "τ = −τ_c·sgn φ̇ (dry friction in the pivot)",
            "N·m",
            "peaks decrease linearly rather than geometrically (by 4τ_c/k per cycle); the "
            "pendulum stops off zero; equation-error LS gives a too-large β and a negative γ",
            "release from two clearly different amplitudes: the linear decrease per cycle "
            "4τ_c/k is the same for both, a quadratic drag decays the large swing faster",
        ),
        PendulumEffect(
            "quadratic_damping",
            "τ = −γ·l³·|φ̇|·φ̇ (quadratic drag of the vehicle)",
            "kg/m",
            "decay faster at large amplitude, slower near rest",
            "release from two clearly different amplitudes",
        ),
    )
}


@dataclass(frozen=True)
class PendulumFit(FitStatistics):
    """A converged output-error fit: coefficients with σ, nuisance per run, residuals (rad)."""

    initial_angle: np.ndarray  # rad, per run
    initial_rate: np.ndarray  # rad/s, per run
    offsets: np.ndarray  # rad, per run (encoder zero)
    rates: tuple[np.ndarray, ...]  # model φ̇ at the samples (rad/s)


def _coeffs(globals_: np.ndarray, effects: Sequence[str]) -> tuple[np.ndarray, ...]:
    """(α, β, γ, τ_c) columns from rows of global parameters."""
    g = np.atleast_2d(globals_)
    col = {n: g[:, i] for i, n in enumerate((*BASE_NAMES, *effects))}
    zero = np.zeros(g.shape[0])
    return (
        col["added_mass"],
        col["linear_damping"],
        col.get("quadratic_damping", zero),
        col.get("pivot_dry_friction", zero),
    )


class _Problem:
    """Residuals and finite-difference Jacobian, one vectorized simulation per run."""

    def __init__(self, decays: Sequence[Decay], effects: Sequence[str], h: Sequence[float]):
        self.decays, self.effects, self.h = decays, tuple(effects), h
        self.ng = len(BASE_NAMES) + len(self.effects)
        self.sizes = [d.t.size for d in decays]
        self.starts = np.concatenate([[0], np.cumsum(self.sizes)]).astype(int)
        self.measured = np.concatenate([d.phi for d in decays])
        self._key: bytes | None = None

    def _run_params(self, params: np.ndarray, r: int) -> tuple[float, float, float]:
        base = self.ng + 3 * r
        return params[base], params[base + 1], params[base + 2]

    def simulate_run(self, params: np.ndarray, r: int, perturb: bool):
        g = params[: self.ng]
        phi0, rate0, _ = self._run_params(params, r)
        rows = [np.r_[g, phi0, rate0]]
        steps = np.zeros(0)
        if perturb:
            full = np.r_[g, phi0, rate0]
            steps = 1e-6 * np.maximum(np.abs(full), 1e-3)
            steps[-1] = 1e-6 * max(abs(rate0), 1e-2)
            rows += list(full + np.diag(steps))
        sets = np.array(rows)
        alpha, beta, gamma, tau = _coeffs(sets[:, : self.ng], self.effects)
        d = self.decays[r]
        angle, rate = simulate(
            d.plant, d.t, alpha, beta, gamma, tau, sets[:, -2], sets[:, -1], self.h[r]
        )
        return np.nan_to_num(angle, nan=1e3, posinf=1e3, neginf=-1e3), rate, steps

    def _evaluate(self, params: np.ndarray) -> None:
        key = params.tobytes()
        if key == self._key:
            return
        n, p = self.measured.size, params.size
        model = np.empty(n)
        jac = np.zeros((n, p))
        for r in range(len(self.decays)):
            angle, _, steps = self.simulate_run(params, r, perturb=True)
            lo, hi = self.starts[r], self.starts[r + 1]
            offset = self._run_params(params, r)[2]
            model[lo:hi] = angle[0] + offset
            diffs = ((angle[1:] - angle[0]) / steps[:, None]).T
            jac[lo:hi, : self.ng] = -diffs[:, : self.ng]
            base = self.ng + 3 * r
            jac[lo:hi, base : base + 2] = -diffs[:, self.ng :]
            jac[lo:hi, base + 2] = -1.0
        self._model, self._jac, self._key = model, jac, key

    def residual(self, params: np.ndarray) -> np.ndarray:
        self._evaluate(params)
        return self.measured - self._model

    def jacobian(self, params: np.ndarray) -> np.ndarray:
        self._evaluate(params)
        return self._jac


def _bounds(decays: Sequence[Decay], effects: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    alpha_min = max(-d.plant.known_inertia / d.plant.arm**2 for d in decays) * (1 - 1e-6)
    lower = [alpha_min, 0.0] + [PENDULUM_EFFECTS[e].lower for e in effects]
    lower += [-np.inf] * (3 * len(decays))
    upper = [np.inf] * len(lower)
    return np.array(lower), np.array(upper)


def effect_start(effect: str, fit: PendulumFit, decays: Sequence[Decay]) -> np.ndarray:
    """Start values (globals of ``fit`` + the new effect) from a grid, nuisance held.

    A new damping effect takes over part of what β carried, and a dry friction started in
    the wrong place stays in a local minimum (it shifts the phase of every later swing), so
    the grid spans the effect (log-spaced) × β (scaled 0.05–1); one vectorized simulation
    per run. τ_c from 1e-4 to 0.2 of the largest restoring torque; γ so that the quadratic
    torque at the largest speed spans 1e-3 to 10× the linear one.
    """
    swing = [float(np.max(np.abs(d.phi - o))) for d, o in zip(decays, fit.offsets, strict=True)]
    beta = max(fit.value("linear_damping"), 1e-3)
    if effect == "pivot_dry_friction":
        top = max(d.plant.stiffness * np.sin(a) for d, a in zip(decays, swing, strict=True))
        values = top * np.geomspace(1e-4, 0.2, 25)
    else:
        speed = max(float(np.max(np.abs(r))) for r in fit.rates) * decays[0].plant.arm
        values = beta / max(speed, 1e-6) * np.geomspace(1e-3, 10, 25)
    scales = np.linspace(0.05, 1.0, 12)
    ev, sc = (a.ravel() for a in np.meshgrid(values, scales))
    sets = np.tile(np.r_[fit.values, 0.0], (ev.size, 1))
    sets[:, -1] = ev
    sets[:, fit.names.index("linear_damping")] = beta * sc
    alpha, beta_, gamma, tau = _coeffs(sets, (*fit.effects, effect))
    sse = np.zeros(ev.size)
    for r, d in enumerate(decays):
        h = step_size(d.t, d.plant, fit.value("added_mass"))
        angle, _ = simulate(
            d.plant, d.t, alpha, beta_, gamma, tau, fit.initial_angle[r], fit.initial_rate[r], h
        )
        res = d.phi[None, :] - angle
        res -= res.mean(axis=1, keepdims=True)
        sse += np.nan_to_num(np.sum(res**2, axis=1), nan=np.inf)
    return sets[int(np.argmin(sse))]


def fit_output_error(
    decays: Sequence[Decay],
    effects: Sequence[str] = (),
    start: np.ndarray | None = None,
    nuisance: np.ndarray | None = None,
) -> PendulumFit:
    """Fit (α, β, effects) and per-run (φ₀, φ̇₀, offset) to all runs' angles jointly.

    ``start``: global start values; ``nuisance``: per-run start values, shape (runs, 3).
    """
    effects = tuple(effects)
    h = [step_size(d.t, d.plant, float(start[0]) if start is not None else 0.0) for d in decays]
    prob = _Problem(decays, effects, h)
    lower, upper = _bounds(decays, effects)
    p0 = np.concatenate([np.asarray(start, float), np.asarray(nuisance, float).ravel()])
    p0 = np.clip(p0, lower, upper)
    on_lower = np.isfinite(lower) & (p0 <= lower)
    p0 = np.where(on_lower, lower + 1e-6 * np.maximum(np.abs(p0), 1e-3), p0)
    sol = least_squares(
        prob.residual, p0, jac=prob.jacobian, bounds=(lower, upper), method="trf",
        x_scale="jac", xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200,
    )  # fmt: skip
    params, ng = sol.x, prob.ng
    res = prob.residual(params)
    stats = solution_statistics(res, prob.jacobian(params), ng, prob.sizes)
    names = (*BASE_NAMES, *effects)
    at_bound = tuple(
        name
        for i, name in enumerate(names)
        if np.isfinite(lower[i]) and params[i] - lower[i] < max(1e-6 * abs(params[i]), 1e-9)
    )
    nuis = params[ng:].reshape(-1, 3)
    rates = tuple(prob.simulate_run(params, r, perturb=False)[1][0] for r in range(len(decays)))
    return PendulumFit(
        effects=effects,
        names=names,
        values=params[:ng].copy(),
        **stats,
        initial_angle=nuis[:, 0].copy(),
        initial_rate=nuis[:, 1].copy(),
        offsets=nuis[:, 2].copy(),
        residuals=tuple(np.split(res, prob.starts[1:-1])),
        rates=rates,
        at_bound=at_bound,
    )


def _nuisance(fit: PendulumFit) -> np.ndarray:
    return np.column_stack([fit.initial_angle, fit.initial_rate, fit.offsets])


def _verdict(effect: str, current: PendulumFit, fit: PendulumFit) -> str:
    """``term_verdict`` for ``fit`` = ``current`` + ``effect`` ("kept", or why not)."""
    explained = float(np.sqrt(max(current.sse - fit.sse, 0.0) / fit.n_samples))
    return term_verdict(
        effect,
        fit.bic - current.bic,
        explained,
        position_noise(fit.residuals),
        identified=bool(np.isfinite(fit.sigma(effect))),
        at_bound=effect in fit.at_bound,
    )


@dataclass(frozen=True)
class PendulumSearch:
    """Base fit, final fit, the evidence for each candidate, ambiguities and advice."""

    base: PendulumFit
    final: PendulumFit
    steps: tuple[SearchStep, ...]
    ambiguous: tuple[tuple[str, ...], ...] = ()
    advice: tuple[str, ...] = ()


def search_effects(
    decays: Sequence[Decay], base: PendulumFit, candidates: Sequence[str] = tuple(PENDULUM_EFFECTS)
) -> PendulumSearch:
    """Greedy forward selection (``estimation.stats.selection``) over ``candidates`` from
    ``base``: each round fits every remaining effect added to the current model and keeps
    the lowest BIC that passes the module's rules; effects explaining the data alike
    (BIC within ``AMBIGUITY_BIC``) are reported as ambiguous with it and not tried again."""
    remaining = list(candidates)
    steps: list[SearchStep] = []
    ambiguous: list[tuple[str, ...]] = []
    advice: list[str] = []

    def extend(current: PendulumFit, round_no: int) -> PendulumFit | None:
        if not remaining:
            return None
        q_current = ljung_box(current.residuals).q_statistic
        trials: dict[str, PendulumFit] = {}  # in the order judged: by BIC

        def fit(added: tuple[str, ...], _: object) -> PendulumFit:
            (effect,) = added
            return fit_output_error(
                decays,
                (*current.effects, effect),
                start=effect_start(effect, current, decays),
                nuisance=_nuisance(current),
            )

        def judge(added: tuple[str, ...], fit: PendulumFit, kept: Mapping) -> bool:
            (effect,) = added
            trials[effect] = fit
            gain = fit.bic - current.bic
            q_new = ljung_box(fit.residuals).q_statistic
            reason = None
            if gain > -BIC_THRESHOLD:
                reason = f"ΔBIC {gain:.1f} > −{BIC_THRESHOLD:g}"
            elif kept:
                reason = f"not added this round: {next(iter(kept))[0]} was kept"
            elif (verdict := _verdict(effect, current, fit)) != "kept":
                reason = verdict
            steps.append(
                SearchStep(
                    effect, gain, None, None, q_current, q_new, reason is None, reason or "kept",
                    round_no,
                )
            )  # fmt: skip
            return reason is None

        chosen = select_round([(e,) for e in remaining], fit, lambda f: f.bic, judge)
        if chosen is None:
            return None
        (name,), kept_fit = chosen
        gain = kept_fit.bic - current.bic
        twins = [
            e
            for e, f in trials.items()
            if e != name
            and f.bic - current.bic <= -BIC_THRESHOLD
            and abs(f.bic - current.bic - gain) < AMBIGUITY_BIC
            and _verdict(e, current, f) == "kept"
        ]
        if twins:
            group = (name, *twins)
            ambiguous.append(group)
            parts = "; ".join(f"{e}: {PENDULUM_EFFECTS[e].separated_by}" for e in group)
            advice.append(f"{' and '.join(group)} explain the data alike — {parts}")
        remaining[:] = [e for e in remaining if e != name and e not in twins]
        return kept_fit

    final = forward_selection(base, extend)
    return PendulumSearch(base, final, tuple(steps), tuple(ambiguous), tuple(advice))
