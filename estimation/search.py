"""Forward effect search: add one effect at a time, refit by output error, keep it only if it
lowers the leave-one-run-out error AND the BIC AND whitens the residual (Ljung–Box Q)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from estimation.diagnostics import ljung_box
from estimation.effects import EFFECTS
from estimation.model import PreparedRun
from estimation.output_error import FitResult, fit_output_error, leave_one_run_out_rmse

BIC_THRESHOLD = 10.0  # "very strong" evidence: BIC must drop by more than this
SCREEN_NFEV = 12  # model evaluations per candidate while screening; the kept one is refitted
RESOLUTION_SIGMAS = 3.0  # a delay within 3σ of the release timing's resolution is not one
MATERIAL_FRACTION = 0.005  # an effect below 0.5 % of the drive is within the drive's uncertainty
AMBIGUITY_BIC = 2.0  # two effects whose BIC drops differ by less than this explain the data alike
PAIR_EXPERIMENTS = {
    frozenset({"coulomb_friction", "constant_bias"}): (
        "coulomb_friction and constant_bias are collinear when every run moves the same way: "
        "add a reverse tow/spin (opposite force) or a free-decay run"
    ),
}


@dataclass(frozen=True)
class SearchStep:
    """Evidence for one candidate effect at one iteration."""

    effect: str
    delta_bic: float
    cv_before: float | None
    cv_after: float | None
    ljung_box_before: float
    ljung_box_after: float
    accepted: bool
    reason: str
    round: int = 1  # forward-selection round (1 = first effect tried on the base model)


@dataclass(frozen=True)
class SearchOutcome:
    """Base fit, final fit, the steps taken and the ambiguities found."""

    base: FitResult
    final: FitResult
    cv_base: float | None
    cv_final: float | None
    steps: tuple[SearchStep, ...]
    ambiguous: tuple[tuple[str, ...], ...] = ()
    advice: tuple[str, ...] = field(default=())


def candidate_effects(runs_declared_mass: bool) -> list[str]:
    """Effects worth trying: drive_inertia only when the hung mass is not declared."""
    names = list(EFFECTS)
    if runs_declared_mass:
        names.remove("drive_inertia")
    return names


def _start(fit: FitResult, effect: str, runs: Sequence[PreparedRun]) -> np.ndarray:
    init = {"coulomb_friction": 0.01 * min(r.mean_abs_drive for r in runs), "drive_inertia": 0.1}
    return np.concatenate([fit.values, [init.get(effect, 0.0)]])


def _effect_force(effect: str, value: float, run: PreparedRun, velocity: np.ndarray) -> float:
    """Largest force/torque the effect exerts over one run's data (N or N·m)."""
    if effect in ("coulomb_friction", "constant_bias"):
        return abs(value)
    if effect == "restoring_spring":
        return abs(value) * float(np.max(np.abs(run.x - run.x[0]), initial=0.0))
    if effect == "cubic_drag":
        return abs(value) * float(np.max(np.abs(velocity), initial=0.0)) ** 3
    if effect == "drive_inertia" and velocity.size > 1:
        accel = np.gradient(velocity, run.t)
        return abs(value) * run.weight_equivalent * float(np.max(np.abs(accel)))
    return np.inf


def _below_resolution(effect: str, fit: FitResult, runs: Sequence[PreparedRun]) -> str | None:
    """Why an effect is too small to be a physical finding, or None.

    Statistics alone would name effects far below what the experiment resolves:
    - a release delay is a start-time offset; when the release instant itself is only known
      to ±σ_t (host timing), an offset within 3σ_t is timing, not stiction;
    - any other effect must reach MATERIAL_FRACTION of the drive on at least one run: a
      force smaller than the uncertainty of the drive itself (weights, g, pulley) cannot be
      told from a slightly wrong drive.
    """
    value = fit.value(effect)
    if effect == "release_delay":
        timing = max((r.t_release_std for r in runs), default=0.0)
        if abs(value) < RESOLUTION_SIGMAS * timing:
            return (
                f"{abs(value) * 1e3:.1f} ms is within the release-timing resolution "
                f"({RESOLUTION_SIGMAS:g} × {timing * 1e3:.1f} ms)"
            )
        return None
    share = max(
        _effect_force(effect, value, run, vel) / max(run.mean_abs_drive, 1e-12)
        for run, vel in zip(runs, fit.velocities, strict=True)
    )
    if share < MATERIAL_FRACTION:
        return (
            f"not material: at most {share:.2%} of the drive "
            f"(below {MATERIAL_FRACTION:.1%}, the drive's own uncertainty)"
        )
    return None


def _separating_advice(group: Sequence[str]) -> str:
    key = frozenset(group)
    if key in PAIR_EXPERIMENTS:
        return PAIR_EXPERIMENTS[key]
    parts = "; ".join(f"{e}: {EFFECTS[e].separated_by}" for e in group)
    return f"{' and '.join(group)} explain the data equally: to separate them — {parts}"


def search_effects(
    runs: Sequence[PreparedRun], base: FitResult, candidates: Sequence[str]
) -> SearchOutcome:
    """Greedy forward selection of effects over ``candidates`` starting from ``base``."""
    current = base
    cv_current = leave_one_run_out_rmse(runs, base)
    cv_base = cv_current
    q_current = ljung_box(base.residuals).q_statistic
    remaining = list(candidates)
    steps: list[SearchStep] = []
    ambiguous: list[tuple[str, ...]] = []
    advice: list[str] = []
    round_no = 0
    while remaining:
        round_no += 1
        first_step = len(steps)
        trials = {
            e: fit_output_error(
                runs, (*current.effects, e), start=_start(current, e, runs), max_nfev=SCREEN_NFEV
            )
            for e in remaining
        }
        gains = {e: f.bic - current.bic for e, f in trials.items()}
        best_gain = min(gains.values())
        # effects that explain the data alike are tried in library order (most common first)
        near = [e for e in remaining if gains[e] - best_gain < AMBIGUITY_BIC]
        order = near + sorted((e for e in remaining if e not in near), key=lambda e: gains[e])
        accepted = None
        for e in order:
            fit = trials[e]
            q_new = ljung_box(fit.residuals).q_statistic
            if gains[e] > -BIC_THRESHOLD:
                steps.append(
                    SearchStep(
                        e,
                        gains[e],
                        cv_current,
                        None,
                        q_current,
                        q_new,
                        False,
                        f"ΔBIC {gains[e]:.1f} > −{BIC_THRESHOLD:g}",
                    )
                )
                continue
            if e in fit.at_bound:
                steps.append(
                    SearchStep(
                        e,
                        gains[e],
                        cv_current,
                        None,
                        q_current,
                        q_new,
                        False,
                        "value at its physical bound",
                    )
                )
                continue
            below = _below_resolution(e, fit, runs)
            if below:
                steps.append(
                    SearchStep(e, gains[e], cv_current, None, q_current, q_new, False, below)
                )
                continue
            cv_new = leave_one_run_out_rmse(runs, fit)
            cv_ok = cv_new is None or cv_current is None or cv_new < cv_current
            white_ok = q_new < q_current
            ok = cv_ok and white_ok
            reason = (
                "kept"
                if ok
                else (
                    "leave-one-run-out error did not drop"
                    if not cv_ok
                    else "residual not whiter (Ljung–Box Q did not drop)"
                )
            )
            steps.append(SearchStep(e, gains[e], cv_current, cv_new, q_current, q_new, ok, reason))
            if ok:
                accepted = (e, fit, cv_new, q_new)
                break
        steps[first_step:] = [replace(st, round=round_no) for st in steps[first_step:]]
        if accepted is None:
            break
        name, fit, cv_new, q_new = accepted
        fit = fit_output_error(runs, fit.effects, start=fit.values)  # converge fully
        logged = {st.effect for st in steps[-len(order) :]}
        for e in order:
            if e not in logged:
                q_e = ljung_box(trials[e].residuals).q_statistic
                steps.append(
                    SearchStep(
                        e,
                        gains[e],
                        cv_current,
                        None,
                        q_current,
                        q_e,
                        False,
                        f"not added this round: {name} was kept",
                        round_no,
                    )
                )
        twins = [
            e
            for e in order
            if e != name
            and gains[e] <= -BIC_THRESHOLD
            and abs(gains[e] - gains[name]) < AMBIGUITY_BIC
            and e not in trials[e].at_bound
        ]
        if twins:
            group = (name, *twins)
            ambiguous.append(group)
            advice.append(_separating_advice(group))
        current, cv_current, q_current = fit, cv_new, q_new
        remaining = [e for e in remaining if e != name and e not in twins]
    return SearchOutcome(
        base=base,
        final=current,
        cv_base=cv_base,
        cv_final=cv_current,
        steps=tuple(steps),
        ambiguous=tuple(ambiguous),
        advice=tuple(advice),
    )
