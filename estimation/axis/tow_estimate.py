"""The one public entry point: ``estimate(runs, method, search_effects)``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from functools import partial

import numpy as np

from estimation.axis import METHODS
from estimation.axis.drive_uncertainty import DriveUncertainty, drive_uncertainty
from estimation.axis.effects import EFFECTS
from estimation.axis.force_residual import force_residuals, regressor_correlations
from estimation.axis.model import BASE_NAMES, at_step_limit, records_of, setup_of
from estimation.axis.output_error import (
    MotionFit,
    evaluate_parameters,
    fit_output_error,
    leave_one_run_out_rmse,
)
from estimation.axis.prepared_run import PreparedRun, prepare
from estimation.axis.release import fit_release, speed_at_release
from estimation.axis.reverse import (
    FRICTION_AND_BIAS,
    ReverseTest,
    opposite_run,
    suggest_reverse_test,
)
from estimation.axis.seed_methods import SEED_METHODS, LeastSquaresFit
from estimation.axis.tow_repeats import LOOK_FOR, analyse_tow_repeats, without_excluded
from estimation.axis.tow_search import candidate_effects, tow_search
from estimation.axis.tow_section import UNITS, TowResult, TowSection
from estimation.axis.unexplained import characterise
from estimation.blas_threads import one_blas_thread
from estimation.data.driven_axes import DRIVEN_AXES, driven_axis
from estimation.data.run_arrays import RunData, validate_runs
from estimation.design.advice import (
    both_ways,
    different_force_advice,
    reverse_advice,
    separating_hint,
)
from estimation.design.planning_envelope import RigEnvelope
from estimation.errors import EstimationFailed
from estimation.kind_advice import advice_for
from estimation.motion.equation import SETTLES_WITHIN
from estimation.motion.estimation_result import EffectEstimate, EstimationResult
from estimation.motion.record_bootstrap import Bootstrap, record_bootstrap
from estimation.motion.term_search import SearchOutcome, search_terms
from estimation.motion.terms import units_of
from estimation.motion.well_determined import Combination, drags_at_speeds, terminal_speeds
from estimation.report_numbers import Coefficient
from estimation.stats.acceptance_rules import TOW_RULES
from estimation.stats.diagnostics import ljung_box
from estimation.stats.fit_statistics import Combinations
from estimation.stats.method_bias import method_bias
from estimation.stats.misfit import lag_one
from estimation.stats.repeatability import outlier_warnings

SEPARABILITY_LIMIT = 0.95
#: A coefficient within this many σ of zero is not determined by the data (its 95 %
#: interval holds zero: not even its sign is known).
NOT_DETERMINED_SIGMAS = 2.0


@one_blas_thread
def estimate(
    runs: Sequence[RunData],
    method: str = "output-error",
    search_effects: bool = True,
    n_bootstrap: int = 40,
    seed: int = 0,
    envelope: RigEnvelope | None = None,
    exclude_outliers: bool = False,
) -> TowResult:
    """Estimate inertia, K_L and K_Q of one axis from runs, with σ, effects and evidence.

    Model: (M + M_drive)·v̇ + K_L·v + K_Q·|v|·v = τ (+ effects found in the residual).
    ``method``: "output-error" (default, joint fit of all runs' positions) or one of the
    seed's "ls-raw", "ls-curvefit", "ls-steady". Effect search and the run-level bootstrap
    apply to output-error only. ``envelope``: what the rig can run
    (``estimation.design``); the advice then names only tests within it. The runs' repeats
    are compared (``axis.tow_repeats``): a Chauvenet outlier is named in the warnings and
    kept in the fit, or left out with ``exclude_outliers``, as a decay's.
    """
    if method not in METHODS:
        raise ValueError(f"method: got {method!r}, allowed: {', '.join(METHODS)}")
    if n_bootstrap < 0:
        raise ValueError(f"n_bootstrap: got {n_bootstrap}, allowed: >= 0")
    axis = validate_runs(runs)
    repeats = analyse_tow_repeats(runs, exclude_outliers)
    runs = without_excluded(runs, repeats)
    found = (*outlier_warnings(repeats, "run", LOOK_FOR),)
    if method != "output-error":
        runs = [fit_release(r) for r in runs]
        result = _seed_result(axis, method, runs, list(map(prepare, runs)))
    else:
        try:
            result = _output_error(axis, runs, search_effects, n_bootstrap, seed, envelope)
        except NUMERICAL_FAILURES as err:  # the runs were valid: the numerics failed
            ids = ", ".join(r.run_id for r in runs)
            raise EstimationFailed(
                f"the {runs[0].dof_name} model to runs {ids}", f"{type(err).__name__}: {err}"
            ) from err
    # one dof per fit: what the texts call the axis
    warnings = (*result.warnings, *found)
    return replace(result, dof=runs[0].dof, repeats=repeats, warnings=warnings)


#: What a fit of valid runs can raise when its numerics fail (scipy's optimisers say
#: "Residuals are not finite" as a ValueError): re-raised as ``EstimationFailed``.
NUMERICAL_FAILURES = (
    ValueError,
    np.linalg.LinAlgError,
    FloatingPointError,
    OverflowError,
    ZeroDivisionError,
)


def _output_error(
    axis: str,
    runs: Sequence[RunData],
    search_effects: bool,
    n_bootstrap: int,
    seed: int,
    envelope: RigEnvelope | None = None,
) -> TowResult:
    """The output-error estimate of validated runs (``estimate``)."""
    method = "output-error"
    runs = [fit_release(r) for r in runs]
    prepared = [prepare(r) for r in runs]
    base = fit_output_error(prepared)
    if search_effects:
        # drive_inertia is a candidate only for weight-driven runs without a declared weight
        declared = all(r.hung_mass_declared() or not r.is_constant_drive() for r in runs)
        outcome = search_terms(
            records_of(prepared),
            setup_of(prepared),
            base,
            candidate_effects(declared),
            tow_search(prepared),
        )
    else:
        cv = leave_one_run_out_rmse(prepared, base)
        outcome = SearchOutcome(
            base=base, final=base, cv_base=cv, cv_final=cv, steps=(), searched=False
        )
    final = outcome.final
    reverse = _within(suggest_reverse_test(axis, runs, outcome.ambiguous), envelope)
    drives = signed_drives(prepared)
    # the advice for friction vs bias comes from the planner's envelope (never stale)
    advice = tuple(
        reverse_advice(axis, drives, envelope, reverse.command if reverse else None)
        if set(group) >= FRICTION_AND_BIAS
        else text
        for group, text in zip(outcome.ambiguous, outcome.advice, strict=True)
    )
    outcome = replace(outcome, advice=advice)
    if reverse is None and "quadratic_damping" in final.at_bound:  # K_Q at 0: a reverse run
        reverse = _within(opposite_run(axis, runs), envelope)
    boot = _bootstrap(prepared, final, n_bootstrap, seed) if n_bootstrap else None
    return _build(
        axis,
        method,
        runs,
        prepared,
        outcome,
        boot,
        drive_uncertainty(runs, final),
        reverse,
        envelope,
    )


def signed_drives(runs: Sequence[PreparedRun]) -> list[float]:
    """Each run's mean signed drive after its release (N or N·m)."""
    return [float(np.mean(r.drive[r.t > r.t_release])) for r in runs if np.any(r.t > r.t_release)]


def _within(test: ReverseTest | None, envelope: RigEnvelope | None) -> ReverseTest | None:
    """``test`` as the rig can run it: its load cut to the rig's limit (or the thrusters'
    calibrated reach); None when the rig cannot run a reverse test at all."""
    if test is None or envelope is None:
        return test
    env = envelope.driven(test.axis)
    if env is None or env.reverse_travel is None:
        return None
    reach = env.max_load
    if test.thrusters:
        if env.thruster_range is None:
            return None
        reach = min(reach, abs(env.thruster_range[0] if test.drive < 0 else env.thruster_range[1]))
    drive = float(np.sign(test.drive) * min(abs(test.drive), reach))
    allowed = envelope.allows(test.axis, drive, test.drive_kind)
    return replace(test, drive=drive) if allowed else None


def _coefficients(fit: MotionFit, axis: str) -> dict[str, Coefficient]:
    """M, K_L and K_Q with their σ (NaN: not identified) and units on ``axis``."""
    units = units_of(axis)
    return {
        n: Coefficient(fit.value(n), float(fit.std[fit.names.index(n)]), units[n])
        for n in BASE_NAMES
    }


def _distinct_drives(runs: Sequence[PreparedRun]) -> list[float]:
    return sorted({round(r.mean_abs_drive, 6) for r in runs})


def separability_warnings(
    fit: MotionFit,
    runs: Sequence[PreparedRun],
    reverse: ReverseTest | None = None,
    envelope: RigEnvelope | None = None,
    axis: str = "surge",
    searched: bool = True,
) -> list[str]:
    """Warnings for coefficient pairs with |ρ| > 0.95, naming the run that would separate them
    (``reverse``: the reverse run to name when K_Q sits at its bound; ``searched``: whether
    the effect search ran)."""
    out = []
    drives = _distinct_drives(runs)
    n = len(fit.names)
    for i in range(n):
        for j in range(i + 1, n):
            rho = float(fit.correlation[i, j])
            if not abs(rho) > SEPARABILITY_LIMIT:
                continue
            a, b = fit.names[i], fit.names[j]
            if {a, b} == {"linear_damping", "quadratic_damping"}:
                out.append(different_force_advice(axis, drives, rho, envelope))
            else:
                hint = EFFECTS[b].separated_by if b in EFFECTS else "a run at a different force"
                hint = separating_hint(hint, signed_drives(runs))  # never a stale "reverse"
                out.append(
                    f"{a} and {b} are not separable by these runs (ρ = {rho:.3f}): add {hint}"
                )
    if "quadratic_damping" in fit.at_bound:
        out.append(_linear_drag_warning(axis, searched, runs, reverse, envelope))
    return out


def _linear_drag_warning(
    axis: str,
    searched: bool,
    runs: Sequence[PreparedRun],
    reverse: ReverseTest | None,
    envelope: RigEnvelope | None,
) -> str:
    """K_Q held at 0: its causes on this kind of record (``kind_advice``: a rig's tow or
    spin, or runs imported without a rig file) and only the advice that kind can take."""
    kind = advice_for("import" if envelope is None else driven_axis(axis).kind)
    steps = [] if searched else ["estimate again with the effect search on (the default)"]
    # a reverse run is advice only where the rig can make one (a recorded run's envelope)
    if reverse is not None and envelope is not None and not both_ways(signed_drives(runs)):
        steps.append(f"add {kind.reverse_run}: run `{reverse.command}`")
    elif searched:
        steps.append("runs at clearly higher speeds would show whether the drag turns quadratic")
    return (
        "quadratic_damping sits at its lower bound 0: over these runs the drag grows no "
        "faster than linearly with speed — a flow at low Reynolds number (a small or slow "
        "body: the linear damping carries the drag), or a dry friction the model lacks "
        f"({kind.dry_friction}) pulling the law the other way; " + "; or ".join(steps)
    )


def physical_warnings(fit: MotionFit, runs: Sequence[RunData]) -> list[str]:
    """A coefficient the data do not determine (σ NaN), an inertia below the body's own,
    a damping held at its bound 0 is named (values a body cannot have are never silent)."""
    load = driven_axis(runs[0].axis).load_name if runs and runs[0].axis in DRIVEN_AXES else "load"
    out = [
        f"{n} is not identified by these runs (no σ): the data cannot determine it; "
        f"a record with the acceleration from rest (the release) or a run at another {load} "
        "would determine it"
        for n, s in zip(fit.names, fit.std, strict=True)
        if not np.isfinite(s)
    ]
    inertia, sigma = fit.value("inertia"), fit.sigma("inertia")
    if np.isfinite(sigma) and abs(inertia) < NOT_DETERMINED_SIGMAS * sigma:
        out.append(
            f"inertia is not identified by these runs: {inertia:.3g} ± {sigma:.2g} is within "
            f"{NOT_DETERMINED_SIGMAS:g}σ of zero; a record with the acceleration from rest "
            "(the release) would determine it"
        )
    bodies = [r.body_inertia for r in runs if r.body_inertia is not None]
    if bodies and inertia < max(bodies):
        out.append(
            f"inertia {inertia:.4g} is below the body's own {max(bodies):.4g}: not physical "
            "(a record that starts after the release, or a missed acceleration, gives this)"
        )
    if "linear_damping" in fit.at_bound:
        out.append(  # the causes a record can have (never "a negative damping")
            "linear_damping sits at its bound 0 (held there, not identified): over these "
            "runs the drag grows faster than linearly with speed, or a force the model lacks "
            "(a wall or the tank's end slowing the body, a misread release) bends the law; "
            "runs at lower speeds would show the linear part"
        )
    return out


def _bootstrap(runs: Sequence[PreparedRun], fit: MotionFit, n: int, seed: int) -> Bootstrap:
    """The one record bootstrap (``motion.record_bootstrap``) of the runs; a draw with fewer
    distinct drives than the runs have (up to 2) is skipped: K_L and K_Q trade freely on it."""
    records = records_of(runs)
    level = {id(rec): round(run.mean_abs_drive, 6) for rec, run in zip(records, runs, strict=True)}
    needed = min(2, len(_distinct_drives(runs)))
    return record_bootstrap(
        records,
        setup_of(runs),
        fit,
        n,
        seed,
        usable=lambda sample: len({level[id(r)] for r in sample}) >= needed,
    )


def _build(
    axis: str,
    method: str,
    runs: Sequence[RunData],
    prepared: Sequence[PreparedRun],
    outcome: SearchOutcome,
    boot: Bootstrap | None,
    uncertainty: DriveUncertainty | None = None,
    reverse: ReverseTest | None = None,
    envelope: RigEnvelope | None = None,
) -> TowResult:
    """The result document of ``outcome`` (base and final fit, the search's evidence)."""
    base, final = outcome.base, outcome.final
    moving = {
        r.run_id: v
        for r, res in zip(runs, final.residuals, strict=True)
        if (v := speed_at_release(r, lag_one(res))) is not None
    }
    limited = at_step_limit(final.values, final.effects, prepared)
    # what the data cannot determine has no σ, wherever the fit is read (budget, effects)
    final = final.without_sigma(final.names if limited else ("inertia",) if moving else ())
    ids = tuple(r.run_id for r in runs)
    effects = tuple(
        EffectEstimate(
            e, final.value(e), float(final.std[final.names.index(e)]), EFFECTS[e].unit(axis)
        )
        for e in final.effects
    )
    warnings = separability_warnings(
        final, prepared, reverse, envelope, axis, searched=outcome.searched
    )
    warnings += physical_warnings(final, runs)
    coefficients = _coefficients(final, axis)
    if moving:  # the model starts at rest: what the fit says of the inertia is not data
        warnings.append(
            "inertia is not identified: "
            + ", ".join(
                f"run {k!r} is already moving at its release ({v:.3g}/s)" for k, v in moving.items()
            )
            + "; the model starts from rest there, so the record lacks the acceleration that "
            "determines the inertia: give the true release (a record with the at-rest samples)"
        )
    if limited:
        warnings.append(
            "the fitted damping or stiffness is so fast for the inertia that the simulation "
            f"needs its finest step (the motion settles within 1/{SETTLES_WITHIN} of a "
            "sample): the fit may rest on that limit rather than on the data, so no coefficient "
            "is identified (no σ is given)"
        )
    # every method's residual is judged by the one rule; a seed method words its own warning
    unexplained = characterise(final, prepared, axis)
    if method == "output-error" and (text := unexplained.warning(axis, outcome.searched)):
        warnings.append(text)
    force_before = force_residuals(base, prepared)
    return EstimationResult(
        axis=axis,
        method=method,
        runs=ids,
        coefficients=coefficients,
        coefficients_before=_coefficients(base, axis),
        units=dict(UNITS.get(axis, {})),
        effects=effects,
        not_identified=tuple(
            n for n, s in zip(final.names, final.std, strict=True) if not np.isfinite(s)
        ),
        ambiguous=tuple(outcome.ambiguous),
        rmse_before=base.rmse,
        rmse_after=final.rmse,
        rmse_per_run_before=dict(zip(ids, base.rmse_per_run(), strict=True)),
        rmse_per_run_after=dict(zip(ids, final.rmse_per_run(), strict=True)),
        warnings=tuple(warnings),
        advice=tuple(outcome.advice),
        whiteness_before=ljung_box(base.residuals),
        whiteness_after=ljung_box(final.residuals),
        rules=TOW_RULES,
        steps=tuple(outcome.steps),
        cv_before=outcome.cv_base,
        cv_after=outcome.cv_final,
        bootstrap=boot,
        # what the residual's character says of the coefficients
        possibly_biased=unexplained.structured,
        well_determined=well_determined(final, *combination_conditions(final, runs), axis),
        section=TowSection(
            residual_correlations=regressor_correlations(base, prepared, force_before),
            force_rmse_per_run_before=_rms_per_run(ids, force_before),
            force_rmse_per_run_after=_rms_per_run(ids, force_residuals(final, prepared)),
            uncertainty=uncertainty,
            reverse_test=reverse,
            windows={r.run_id: r.window_report() for r in runs},
            drive_laws={r.run_id: r.drive_law for r in runs if r.drive_law},
            unexplained=unexplained,
        ),
        fit_before=base,
        fit_after=final,
        setup=setup_of(prepared),
        records=records_of(prepared),
    )


def combination_conditions(
    final: MotionFit, runs: Sequence[RunData]
) -> tuple[dict[str, float], list[float]]:
    """What a tow's well-determined combinations are evaluated at: each run's constant drive
    (a per-sample drive's over the last fifth of the run, a thruster run's at its end; N or
    N·m; none when it reverses there, as a wave's force does: a drive that changes sign has
    no steady speed), and the speed each run reached (the model's at the end of its window;
    m/s or rad/s)."""
    held = {}
    for r in runs:
        d = np.asarray(r.drive, dtype=float)
        if d.ndim == 0:
            held[r.run_id] = float(d)
            continue
        end = d[-max(d.size // 5, 1) :]
        if not (np.any(end > 0) and np.any(end < 0)):
            held[r.run_id] = float(np.median(end))
    return held, [float(v[-1]) for v in final.velocities if v.size]


def well_determined(
    fit: MotionFit, drives: Mapping[str, float], speeds: Sequence[float], axis: str
) -> tuple[Combination, ...]:
    """The terminal speed at each of the ``drives``, then the drag at each of the
    ``speeds`` (``combination_conditions``), under ``fit``'s coefficients. The budget evaluates
    them at the same conditions on each re-fit with a declared input moved."""
    return (*terminal_speeds(fit, drives, axis), *drags_at_speeds(fit, speeds, axis))


def _rms_per_run(ids: Sequence[str], residuals: Sequence[np.ndarray]) -> dict[str, float]:
    return {i: float(np.sqrt(np.mean(r**2))) for i, r in zip(ids, residuals, strict=True)}


def seed_fit(method: str, prepared: Sequence[PreparedRun]) -> tuple[MotionFit, LeastSquaresFit]:
    """The seed ``method`` on ``prepared`` runs, and its coefficients as the fit a result
    reads (the positions simulated with them, an inertia ≤ 0 at 1e-9: ``_seed_result``
    warns of it); the uncertainty budget re-fits a seed result by this."""
    ls = SEED_METHODS[method](prepared)
    simulated = ls.values if ls.values[0] > 0 else np.r_[1e-9, ls.values[1:]]
    fit = evaluate_parameters(prepared, simulated, ls.std, ls.correlation)
    # its terminal speeds and drags take σ by the delta method through the seed's covariance
    size = ls.values.size
    combinations = Combinations(
        ls.covariance, np.zeros((0, size)), np.ones(size), 1.0, ls.cov_white
    )
    return replace(fit, values=ls.values, combinations=combinations), ls


def _seed_values(method: str, prepared: list[PreparedRun], _fit: MotionFit) -> np.ndarray:
    """The seed ``method``'s coefficients on ``prepared`` runs (moved by a release's σ_t or
    a calibration draw); NaN where its numerics refuse them (a shift the timing row then
    skips, a draw whose spread is then not a number: no calibration row)."""
    try:
        return SEED_METHODS[method](prepared).values
    except (ValueError, RuntimeError, np.linalg.LinAlgError):
        return np.full(len(BASE_NAMES), np.nan)


def _seed_result(axis, method, runs, prepared) -> TowResult:
    fit, ls = seed_fit(method, prepared)  # ``fit`` carries the seed's values and σ
    output_error = fit_output_error(prepared)
    bias = method_bias(method, _coefficients(fit, axis), _coefficients(output_error, axis))
    outcome = SearchOutcome(base=fit, final=fit, cv_base=None, cv_final=None, steps=())
    # the release timing and thrust calibration draws through the seed method itself
    drive = drive_uncertainty(runs, fit, partial(_seed_values, method))
    result = _build(axis, method, runs, prepared, outcome, None, drive)
    # the positions its coefficients predict, judged by the rule every result's residual is;
    # output error's verdict on the same runs says whose the structure is
    misfit = result.section.unexplained
    seed_warnings = list(bias)
    if misfit is not None and misfit.structured:
        reference = characterise(output_error, prepared, axis)
        seed_warnings.append(misfit.seed_warning(method, axis, reference, bool(bias)))
    if not ls.values[0] > 0:
        seed_warnings.append(f"{method}: inertia {ls.values[0]:.4g} ≤ 0 cannot be simulated")
    section = replace(result.section, seed=ls)  # its σ's ν, for the budget's U
    return replace(result, warnings=(*seed_warnings, *result.warnings), section=section)
