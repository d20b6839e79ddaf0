"""The one output-error fit of the one equation, every record kind's: tows and spins,
pendulums and free decays, records of one DOF fitted jointly.

Minimises Σ_records Σ_samples (x_meas − x_eq − ξ(t; θ, ξ₀, ξ̇₀))², where ξ solves

    (M_known + w_M·M + Σ θ_i·w_i)·ξ̈ = τ(t) + Σ_j w_j·θ_j·φ_j(ξ, ξ̇)          (equation.py)

from each record's start: a *free* record (a decay, a pendulum) from the state (ξ₀, ξ̇₀)
at its first sample, its equilibrium x_eq (a spring is anchored there, not at the release
point) and initial state nuisance parameters; a record *at rest until its release* (a tow,
a spin) from ξ = ξ̇ = 0 at ``released_at`` (later by the timing terms), its one nuisance the
position it rests at. Known terms (a hydrostatic stiffness) are fixed; M_known, the known
terms and the weights w of the identified coefficients may differ per record (``Record``:
a pendulum's geometry, a tow's drive train and hung weight). σ from ``identify``,
quantization included (a direction the data cannot determine is reported, not dropped).
Start values from the equation-error least squares on Savitzky–Golay derivatives (or the
caller's: a tow's own, ``axis.output_error.initial_guess``); every parameter is scaled by
its typical size, bounded by its term's bounds; the integrator's step resolves each
trial's period and damping rate (``equation.integration_step``), the closed form of a
constant pull (``constant_pull``) replaces it when it applies, and a trial far from the
data is a large finite misfit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.blas_threads import one_blas_thread
from estimation.errors import EstimationFailed
from estimation.motion import constant_pull, equation
from estimation.motion.equation import (
    STATE_LIMIT,
    Track,
    integrate,
    integration_step,
    total_inertia,
)
from estimation.motion.fit_memo import Recent
from estimation.motion.record_derivatives import derivatives, record_step
from estimation.motion.records import Record, Setup, known_inertia_of, known_terms_of
from estimation.motion.terms import LIBRARY, TermValues
from estimation.stats.fit_statistics import FitStatistics
from estimation.stats.identify import honest_statistics
from estimation.stats.out_of_sample import LORO_MIN_RUNS, LORO_NFEV, REFIT_TOLERANCE, pooled_rmse

#: least_squares' xtol, ftol and gtol of a reported fit (its leave-one-record-out refits use
#: ``stats.out_of_sample.REFIT_TOLERANCE``: their error is judged to √ of it).
FIT_TOLERANCE = 1e-9


@dataclass(frozen=True, kw_only=True)
class MotionFit(FitStatistics):
    """A converged fit: coefficients with σ (NaN: not identified), nuisances, trajectories."""

    equilibrium: np.ndarray  # per record, m or rad (a record at rest: where it rests)
    initial: np.ndarray  # (R, 2): ξ₀ (m or rad), ξ̇₀ (m/s or rad/s); 0 for one at rest
    free: np.ndarray  # per record: starts free (its ξ₀, ξ̇₀ fitted), else at rest
    displacements: tuple[np.ndarray, ...]  # model ξ at the samples
    velocities: tuple[np.ndarray, ...]  # model ξ̇ at the samples
    not_identified: tuple[str, ...] = ()


def names_of(setup: Setup, effects: Sequence[str]) -> tuple[str, ...]:
    """Fitted coefficient names: inertia (unless known), base terms, then effects."""
    head = ("inertia",) if setup.inertia is None else ()
    return (*head, *setup.terms, *effects)


def rest_of(record: Record) -> float:
    """Where the record's ξ = 0 starts out (m or rad): a record at rest, the median of its
    samples up to the release (its first sample without any); a free one, the median of its
    last fifth (where a decay settles)."""
    x = np.asarray(record.x, dtype=float)
    if record.released_at is None:
        return float(np.median(x[-max(x.size // 5, 3) :]))
    held = x[np.asarray(record.t) <= record.released_at]
    return float(np.median(held)) if held.size else float(x[0])


def equation_error_start(records: Sequence[Record], setup: Setup, names: Sequence[str]):
    """Coefficients, equilibria and initial states (ξ₀, ξ̇₀; zeros for a record at rest)
    from least squares on derivatives, over each record's moving samples; a free record's
    equilibrium error is one more (bias) column."""
    rows, rhs, eqs, init = [], [], [], []
    any_free = any(r.free for r in records)
    for r in records:
        t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
        v, a = derivatives(t, x)
        eq = rest_of(r)
        xi = x - eq
        eqs.append(eq)
        init.append((xi[0], v[0]) if r.free else (0.0, 0.0))
        drive = r.drive_at_samples()
        b = (np.zeros_like(t) if drive is None else drive) - known_inertia_of(r, setup) * a
        for n, value in known_terms_of(r, setup).items():
            b = b + value * LIBRARY[n].regressor(xi, v, a, r.hung_weight, t - t[0])
        if setup.inertia is not None:
            b = b - setup.inertia * r.weight("inertia") * a
        cols = [
            r.weight(n)
            * (a if n == "inertia" else -LIBRARY[n].regressor(xi, v, a, r.hung_weight, t - t[0]))
            for n in names
        ]
        if any_free:
            cols.append(np.ones_like(t) if r.free else np.zeros_like(t))
        moving = slice(None) if r.free else t > r.released_at
        rows.append(np.column_stack(cols)[moving])
        rhs.append(b[moving])
    sol = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    return sol[: len(names)], np.array(eqs), np.array(init, dtype=float)


#: A search builds a problem for every fit, fold and prediction on the same records: each
#: record's track (its derivatives' range and speed, and what the track caches itself) is
#: formed once (by the identity of the record and setup, ``fit_memo``).
_TRACKS: Recent[Track] = Recent(size=16)


def _track(record: Record, setup: Setup) -> Track:
    """``track_of(record, setup)``, the same object again for the same record and setup."""
    return _TRACKS.get((record, setup), lambda: track_of(record, setup))


def track_of(record: Record, setup: Setup) -> Track:
    """The record as the integrator reads it: τ from its start (its first sample, or its
    release: held at rest before it), its drive, its known inertia, the weight of the
    inertia terms, its range (the divergence guard) and where the step linearises the
    forces (its largest excursion from ``rest_of`` and its largest speed)."""
    t, x = np.asarray(record.t, dtype=float), np.asarray(record.x, dtype=float)
    start = t[0] if record.released_at is None else record.released_at
    return Track(
        t - start,
        record.drive_at_samples(),
        known_inertia_of(record, setup),
        record.hung_weight,
        float(np.ptp(x)) or 1.0,
        drive_before=record.drive_before,
        reach=float(np.max(np.abs(x - rest_of(record)))),
        speed=float(np.max(np.abs(derivatives(t, x)[0]))),
    )


def _within(x: np.ndarray, limit: float) -> np.ndarray:
    """``x`` held within ±``limit`` (NaN: at +``limit``); ``x`` itself when it is already."""
    if np.all(np.abs(x) <= limit):  # False for NaN and ±inf
        return x
    return np.clip(np.nan_to_num(x, nan=limit, posinf=limit, neginf=-limit), -limit, limit)


class _Problem:
    """Residuals and Jacobian of the joint fit: the identified coefficients, then x_eq per
    record, then ξ₀ and ξ̇₀ per free record (a record at rest starts at ξ = ξ̇ = 0).

    A parameter vector is integrated once with all its finite-difference sets, on the step
    chosen for all of them (one vectorized integration: cheaper than the centre first and
    its sets on demand, ``bench/estimation_speed.py``)."""

    def __init__(
        self,
        records: Sequence[Record],
        setup: Setup,
        names: Sequence[str],
        scale: np.ndarray,
    ) -> None:
        self.scale = scale  # typical size of every parameter (globals, x_eq, ξ₀, ξ̇₀)
        self.records, self.setup, self.names = tuple(records), setup, tuple(names)
        self.ng, self.nr = len(self.names), len(records)
        self.free = np.array([r.free for r in records])
        self.nf = int(self.free.sum())
        self.tracks = [_track(r, setup) for r in records]
        #: each identified coefficient's weight per record (ng, R); known terms per record
        self.weights = np.array([[r.weight(n) for r in records] for n in self.names])
        self.inertia_weight = np.array([r.weight("inertia") for r in records])
        known = dict.fromkeys(n for r in records for n in known_terms_of(r, setup))
        self.known = {
            n: np.array([known_terms_of(r, setup).get(n, 0.0) for r in records]) for n in known
        }
        terms = [LIBRARY[n] for n in (*self.names, *self.known) if n != "inertia"]
        self.closed = constant_pull.applies(records, terms)
        self.sizes = [r.t.size for r in records]
        self.starts = np.concatenate([[0], np.cumsum(self.sizes)])
        self.measured = np.concatenate([np.asarray(r.x, dtype=float) for r in records])
        self.index = np.repeat(np.arange(self.nr), self.sizes)
        self.limit = STATE_LIMIT * (max(float(np.ptp(np.asarray(r.x))) for r in records) + 1.0)
        self._key: bytes | None = None
        # the last parameters evaluated: their finite-difference steps, simulated (ξ, ξ̇)
        # of every set (S, n) and equilibria
        self.x = self.v = np.zeros((0, 0))
        self.eq = self.g_steps = self.x_step = self.v_step = np.zeros(0)
        # the Jacobian's fixed layout: every sample's row; a free record's samples, their
        # rows and the record's slot among the free ones
        self._rows_all = np.arange(self.measured.size)
        self._free_mask = self.free[self.index]
        self._free_rows = self._rows_all[self._free_mask]
        self._free_slot = (np.cumsum(self.free) - 1)[self.index[self._free_mask]]

    def split(self, p: np.ndarray):
        """Globals, x_eq (R), ξ₀ and ξ̇₀ (per free record) of the parameter vector."""
        ng, nr, nf = self.ng, self.nr, self.nf
        return p[:ng], p[ng : ng + nr], p[ng + nr : ng + nr + nf], p[ng + nr + nf :]

    def state(self, xi0: np.ndarray, v0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every record's start state (S, R) from the free records' (S, F): rest elsewhere."""
        x = np.zeros((np.shape(xi0)[0], self.nr))
        v = np.zeros_like(x)
        x[:, self.free], v[:, self.free] = xi0, v0
        return x, v

    def parts(self, g: np.ndarray) -> tuple[np.ndarray, list[TermValues], np.ndarray]:
        """The identified inertia (S, R), every term's values (S, R) and each set's delay
        (s, (S,): the timing terms) of the parameter sets ``g`` (S, ng)."""
        sets = g.shape[0]
        if "inertia" in self.names:
            inertia = g[:, [self.names.index("inertia")]] * self.inertia_weight
        else:
            inertia = np.full((sets, 1), float(self.setup.inertia or 0.0)) * self.inertia_weight
        coeffs = [
            TermValues(LIBRARY[n], g[:, [i]] * self.weights[i])
            for i, n in enumerate(self.names)
            if n != "inertia"
        ]
        coeffs += [
            TermValues(LIBRARY[n], np.broadcast_to(v, (sets, self.nr)))
            for n, v in self.known.items()
        ]
        delay = np.zeros(sets)
        for c in coeffs:
            if c.term.role == "timing":
                delay = delay + c.value[:, 0]
        return inertia, coeffs, delay

    def step(self, g: np.ndarray) -> tuple[float, np.ndarray]:
        """The integrator's step for the sets ``g`` (S, ng) and which it cannot resolve."""
        return self._step(*self.parts(g)[:2])

    def _step(self, inertia: np.ndarray, coeffs: list[TermValues]) -> tuple[float, np.ndarray]:
        total = total_inertia(self.tracks, inertia, coeffs)
        return integration_step(self.tracks, total, [c for c in coeffs if c.term.role == "force"])

    def simulate(
        self,
        g: np.ndarray,
        xi0: np.ndarray,
        v0: np.ndarray,
        rows: slice = slice(None),
    ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per record (ξ, ξ̇) at the samples of the parameter sets ``g[rows]`` (g: (S, ng))
        from the free records' start states (S, F), on the step chosen for all of ``g``
        (so each set's path is the same whichever sets run beside it), finite and within
        the divergence limit. A force term that is zero in every set of ``g`` is skipped:
        it exerts nothing (dry friction's set-valued branch costs most)."""
        inertia, coeffs, delay = self.parts(g)
        with np.errstate(over="ignore", invalid="ignore"):
            if self.closed:
                total = total_inertia(self.tracks, inertia[rows], self._rows(coeffs, rows))
                sims = constant_pull.pull_response(
                    self.records, total, self._rows(coeffs, rows), delay[rows]
                )
            else:
                h, unresolved = self._step(inertia, coeffs)
                active = [c for c in coeffs if c.term.role != "force" or np.any(c.value)]
                x0, v0_ = self.state(xi0[rows], v0[rows])
                sims = integrate(
                    self.tracks,
                    inertia[rows],
                    self._rows(active, rows),
                    x0,
                    v0_,
                    h,
                    shift=delay[rows] if np.any(delay) else None,
                    unresolved=unresolved[rows],
                )
        return [(_within(x, self.limit), v) for x, v in sims]

    @staticmethod
    def _rows(coeffs: list[TermValues], rows: slice) -> list[TermValues]:
        return [TermValues(c.term, c.value[rows]) for c in coeffs]

    def _evaluate(self, p: np.ndarray) -> None:
        """The model at ``p`` (row 0) and every finite-difference set (each coefficient,
        then all free records' ξ₀, then their ξ̇₀), in one integration: a parameter vector
        is integrated once, whether the fit asks for its residual, its Jacobian or both
        (an accepted trial step asks for both)."""
        key = p.tobytes()
        if key == self._key:
            return
        g, eq, xi0, v0 = self.split(p)
        self.g_steps = 1e-6 * np.maximum(np.abs(g), self.scale[: self.ng] * 1e-3)
        ng, nr, nf = self.ng, self.nr, self.nf
        self.x_step = 1e-6 * np.maximum(np.abs(xi0), self.scale[ng + nr : ng + nr + nf])
        self.v_step = 1e-6 * np.maximum(np.abs(v0), self.scale[ng + nr + nf :])
        extra = 2 if nf else 0
        sets = np.vstack([g, g + np.diag(self.g_steps), *([g] * extra)])
        x0 = np.vstack([xi0] * (ng + 1) + ([xi0 + self.x_step, xi0] if nf else []))
        v0s = np.vstack([v0] * (ng + 1) + ([v0, v0 + self.v_step] if nf else []))
        sims = self.simulate(sets, x0, v0s)
        self.x = np.concatenate([s[0] for s in sims], axis=1)
        self.v = np.concatenate([s[1] for s in sims], axis=1)
        self.eq = eq
        self._key = key

    def centre_residual(self, p: np.ndarray) -> np.ndarray:
        """``residual(p)`` where only the residual is read (a prediction, a refit's finite
        check): the finite-difference sets choose the step, as in ``_evaluate``, but only the
        centre is integrated (``simulate``'s rows: the same numbers)."""
        if p.tobytes() == self._key:
            return self.measured - self.model
        g, eq, xi0, v0 = self.split(p)
        steps = 1e-6 * np.maximum(np.abs(g), self.scale[: self.ng] * 1e-3)
        sets = np.vstack([g, g + np.diag(steps)])
        sims = self.simulate(sets, xi0[None, :], v0[None, :], rows=slice(0, 1))
        x = np.concatenate([s[0] for s in sims], axis=1)
        return self.measured - (x[0] + eq[self.index])

    @property
    def model(self) -> np.ndarray:
        """The modelled positions at the last parameters evaluated (m or rad)."""
        return self.x[0] + self.eq[self.index]

    def residual(self, p: np.ndarray) -> np.ndarray:
        self._evaluate(p)
        return self.measured - self.model

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        self._evaluate(p)
        ng, nr, nf = self.ng, self.nr, self.nf
        jac = np.zeros((self.measured.size, p.size))
        jac[:, :ng] = -((self.x[1 : ng + 1] - self.x[0]) / self.g_steps[:, None]).T
        jac[self._rows_all, ng + self.index] = -1.0
        if nf:  # free record k's own ξ₀/ξ̇₀ columns: its samples only
            at, k = self._free_rows, self._free_slot
            own = slice(None) if nf == nr else self._free_mask
            jac[at, ng + nr + k] = -(self.x[ng + 1, own] - self.x[0, own]) / self.x_step[k]
            jac[at, ng + nr + nf + k] = -(self.x[ng + 2, own] - self.x[0, own]) / self.v_step[k]
        return jac


def _bounds(records: Sequence[Record], setup: Setup, names: Sequence[str], typical: np.ndarray):
    """The coefficients' bounds (the total inertia stays positive on every record; each
    term's own), then none on the nuisances."""
    nuisances = len(records) + 2 * sum(r.free for r in records)
    lo, hi = [], []
    for n, s in zip(names, typical, strict=True):
        if n == "inertia":
            low = max(-known_inertia_of(r, setup) / r.weight("inertia") for r in records)
            lo.append(low + 1e-9 * max(s, -low))
            hi.append(np.inf)
        else:
            lo.append(LIBRARY[n].lower)
            hi.append(LIBRARY[n].upper)
    return np.array(lo + [-np.inf] * nuisances), np.array(hi + [np.inf] * nuisances)


def _nuisance_scale(records: Sequence[Record]) -> np.ndarray:
    """Typical sizes of x_eq (R), ξ₀ and ξ̇₀ (per free record): the records' largest range
    and largest speed."""
    amp = max(float(np.ptp(np.asarray(r.x))) for r in records) or 1.0
    speed = max(float(np.ptp(derivatives(np.asarray(r.t), np.asarray(r.x))[0])) for r in records)
    nf = sum(r.free for r in records)
    return np.concatenate(
        [np.full(len(records), amp), np.full(nf, amp), np.full(nf, max(speed, 1e-12))]
    )


def _solve(
    records: Sequence[Record],
    setup: Setup,
    names: Sequence[str],
    start: np.ndarray | None,
    max_nfev: int,
    tolerance: float,
) -> tuple[_Problem, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The joint least squares (``fit_motion``): its problem, the solution (globals, x_eq,
    ξ₀, ξ̇₀), the bounds and each coefficient's typical size. ``start``: the globals, or
    the whole vector, to start from (else the equation-error least squares)."""
    ng = len(names)
    free = np.array([r.free for r in records])
    g0, eq0, init0 = equation_error_start(records, setup, names)
    typical = _typical(records, setup, names, g0)
    nuisances = np.concatenate([eq0, init0[free, 0], init0[free, 1]])
    if start is not None:
        start = np.asarray(start, dtype=float)
        g0 = start[:ng]
        if start.size > ng:
            nuisances = start[ng:]
    lower, upper = _bounds(records, setup, names, typical)
    p0 = np.concatenate([g0, nuisances])
    nudge = np.concatenate([1e-6 * typical, np.zeros(nuisances.size)])
    p0 = np.clip(np.where(np.isfinite(p0), p0, 0.0), lower, upper)
    p0 = np.where(np.isfinite(lower) & (p0 <= lower), lower + nudge, p0)
    prob = _Problem(records, setup, names, np.concatenate([typical, _nuisance_scale(records)]))
    from scipy.optimize import least_squares  # here: the service imports this module's types

    sol = least_squares(
        prob.residual,
        p0,
        jac=prob.jacobian,
        bounds=(lower, upper),
        method="trf",
        x_scale=prob.scale,
        xtol=tolerance,
        ftol=tolerance,
        gtol=tolerance,
        max_nfev=max_nfev,
    )
    return prob, sol.x, lower, upper, typical


@one_blas_thread
def fit_motion(
    records: Sequence[Record],
    setup: Setup,
    effects: Sequence[str] = (),
    start: np.ndarray | None = None,
    max_nfev: int = 100,
    quantization_sigma: bool = True,
) -> MotionFit:
    """Fit the identified coefficients and each record's nuisances (module doc).

    ``start``: the globals, or the full parameter vector of a previous fit
    (``parameters_of``), to go on from. ``quantization_sigma``: False for a refit whose σ
    is discarded (a bootstrap draw, a leave-one-out refit): the quantization σ, the
    costliest part, is not computed (``std_quantization`` None).
    """
    names = names_of(setup, effects)
    prob, p, lower, upper, typical = _solve(records, setup, names, start, max_nfev, FIT_TOLERANCE)
    res = _finite(prob.residual(p), setup, names)
    fitted = prob.measured - res
    steps = (
        [record_step(r.x) if r.quantum is None else r.quantum for r in records]
        if quantization_sigma
        else []
    )
    stats = honest_statistics(res, prob.jacobian(p), len(names), prob.sizes, fitted, steps)
    # at a bound: within 1e-6 of the coefficient's typical size (or its value) of it (the
    # trust region approaches a bound it rests on without reaching it: a K_Q of 7e-8 against
    # a typical 1.8 kg/m is a drag law pinned at 0)
    tol = 1e-6 * np.maximum(np.abs(p[: len(names)]), typical)
    at_bound = tuple(
        n
        for n, v, lo, hi, e in zip(names, p, lower, upper, tol, strict=False)
        if abs(v - lo) < e or abs(v - hi) < e
    )
    g, eq, xi0, v0 = prob.split(p)
    prob.residual(p)
    initial = np.zeros((len(records), 2))
    initial[prob.free] = np.column_stack([xi0, v0])
    return MotionFit(
        effects=tuple(effects),
        names=names,
        values=g.copy(),
        **stats.fit_fields(),
        residuals=tuple(np.split(res, prob.starts[1:-1])),
        at_bound=at_bound,
        equilibrium=eq.copy(),
        initial=initial,
        free=prob.free.copy(),
        displacements=tuple(np.split(prob.x[0], prob.starts[1:-1])),
        velocities=tuple(np.split(prob.v[0], prob.starts[1:-1])),
        not_identified=tuple(
            n for n, lost in zip(names, stats.not_identified, strict=True) if lost
        ),
    )


@one_blas_thread
def fitted_values(
    records: Sequence[Record],
    setup: Setup,
    effects: Sequence[str],
    start: np.ndarray,
    max_nfev: int,
) -> np.ndarray:
    """The coefficients ``fit_motion`` finds (``names_of``'s order), the same numbers, for a
    refit whose σ and residuals are discarded (a bootstrap draw): nothing else computed."""
    names = names_of(setup, effects)
    prob, p, *_ = _solve(records, setup, names, start, max_nfev, FIT_TOLERANCE)
    _finite(prob.centre_residual(p), setup, names)
    return prob.split(p)[0].copy()


def _finite(res: np.ndarray, setup: Setup, names: Sequence[str]) -> np.ndarray:
    """``res``, the residual of a converged fit; raises ``EstimationFailed`` unless finite."""
    if not np.all(np.isfinite(res)):
        raise EstimationFailed(
            f"the {setup.dof} equation with {', '.join(names)}",
            "the simulated motion did not stay finite from any start",
        )
    return res


def parameters_of(fit: MotionFit, records: Sequence[int] | None = None) -> np.ndarray:
    """The full parameter vector of ``fit`` (globals, x_eq, then ξ₀ and ξ̇₀ of the free
    records) to restart from; ``records``: of the fit's records at these indices only, in
    this order (repeats allowed: a leave-one-out fold, a bootstrap draw)."""
    keep = np.arange(len(fit.equilibrium)) if records is None else np.asarray(records, dtype=int)
    eq, initial, free = fit.equilibrium[keep], fit.initial[keep], fit.free[keep]
    return np.concatenate([fit.values, eq, initial[free, 0], initial[free, 1]])


@dataclass(frozen=True)
class HeldOut:
    """A leave-one-record-out check: the pooled RMSE of the held-out records' predictions
    and each fold's (m or rad; in the records' order)."""

    rmse: float
    per_record: tuple[float, ...]
    #: samples of each held-out record (the folds' weights in the pooled RMSE)
    sizes: tuple[int, ...] = ()

    def pooled_over(self, folds: Sequence[int]) -> float:
        """The pooled RMSE of the folds ``folds`` alone (m or rad)."""
        n = sum(self.sizes[i] for i in folds)
        return float(np.sqrt(sum(self.sizes[i] * self.per_record[i] ** 2 for i in folds) / n))


@one_blas_thread
def leave_one_record_out(records: Sequence[Record], setup: Setup, fit: MotionFit) -> HeldOut | None:
    """Each record predicted by the shared coefficients refitted on the others (None with
    fewer than ``LORO_MIN_RUNS`` records).

    Per fold: ``fit``'s coefficients and the other records' nuisances are refitted from
    ``fit``'s optimum (``LORO_NFEV`` evaluations, ``REFIT_TOLERANCE``); the held-out record
    is then simulated with those coefficients fixed, fitting only its own nuisances
    (``predict_record``). Raises ``EstimationFailed`` when a refit or a prediction does
    not stay finite."""
    nr = len(records)
    if nr < LORO_MIN_RUNS:
        return None
    ng = len(fit.names)
    held_out = []
    for i, start in enumerate(_fold_starts(records, setup, fit)):
        train = [r for j, r in enumerate(records) if j != i]
        prob, sub, *_ = _solve(train, setup, fit.names, start, LORO_NFEV, REFIT_TOLERANCE)
        if not np.all(np.isfinite(prob.centre_residual(sub))):
            raise EstimationFailed(
                f"the {setup.dof} equation with {', '.join(fit.names)} without record "
                f"{records[i].run_id}",
                "the refitted motion did not stay finite",
            )
        held_out.append(predict_record(records[i], setup, fit.names, sub[:ng], fit, i))
    per_record = tuple(float(np.sqrt(np.mean(r**2))) for r in held_out)
    return HeldOut(pooled_rmse(held_out), per_record, tuple(r.size for r in held_out))


def _fold_starts(records: Sequence[Record], setup: Setup, fit: MotionFit) -> list[np.ndarray]:
    """Each leave-one-record-out fold's start: ``fit``'s parameters without the held-out
    record's nuisances, moved by one Gauss–Newton step on the other records' rows of
    ``fit``'s own Jacobian (scaled by each parameter's size; one evaluation for all folds).
    At ``fit``'s optimum the gradient of the whole is zero, so this step is the fold's
    first-order correction for the record it leaves out: the refit starts near its own
    optimum (the bench's pair search: 98 → 81 fold evaluations) and converges to it as
    before. A Jacobian that is not finite leaves the plain starts."""
    nr, ng = len(records), len(fit.names)
    plain = [parameters_of(fit, [j for j in range(nr) if j != i]) for i in range(nr)]
    scale = np.concatenate([np.maximum(np.abs(fit.values), 1e-12), _nuisance_scale(records)])
    whole = _Problem(records, setup, fit.names, scale)
    p = parameters_of(fit)
    res, jac = whole.residual(p), whole.jacobian(p)
    if not (np.all(np.isfinite(res)) and np.all(np.isfinite(jac))):
        return plain
    slot = np.cumsum(whole.free) - 1  # a free record's place among the free ones
    starts = []
    for i, start in enumerate(plain):
        others = [j for j in range(nr) if j != i]
        free = slot[[j for j in others if whole.free[j]]]
        cols = np.concatenate(
            [np.arange(ng), ng + np.array(others), ng + nr + free, ng + nr + whole.nf + free]
        ).astype(int)
        rows = whole.index != i
        d = scale[cols]
        step = np.linalg.lstsq(jac[np.ix_(rows, cols)] * d, res[rows], rcond=None)[0] * d
        starts.append(start - step)
    return starts


def predict_record(
    record: Record,
    setup: Setup,
    names: Sequence[str],
    values: np.ndarray,
    fit: MotionFit | None = None,
    index: int = 0,
) -> np.ndarray:
    """Residual of ``record`` under fixed coefficients ``values`` (``names``), fitting only
    its own nuisances (x_eq; ξ₀, ξ̇₀ when free) to ``REFIT_TOLERANCE``, from ``fit``'s for
    the record at ``index`` (else the equation-error start's)."""
    ng = len(names)
    if fit is None:
        _, eq0, init0 = equation_error_start([record], setup, names)
        state = init0[0]
    else:
        eq0, state = fit.equilibrium[[index]], fit.initial[index]
    nuisance = np.concatenate([eq0, state if record.free else []])
    scale = np.concatenate([np.maximum(np.abs(values), 1e-12), _nuisance_scale([record])])
    prob = _Problem([record], setup, names, scale)
    if not record.free:  # its one nuisance, the rest position, enters linearly: the mean
        res = prob.centre_residual(np.concatenate([values, [0.0]]))
        return res - np.mean(res)
    from scipy.optimize import least_squares  # here: the service imports this module's types

    sol = least_squares(
        lambda q: prob.residual(np.concatenate([values, q])),
        np.asarray(nuisance, dtype=float),
        jac=lambda q: prob.jacobian(np.concatenate([values, q]))[:, ng:],
        method="trf",
        x_scale=scale[ng:],
        xtol=REFIT_TOLERANCE,
        ftol=REFIT_TOLERANCE,
        gtol=REFIT_TOLERANCE,
        max_nfev=LORO_NFEV,
    )
    res = prob.residual(np.concatenate([values, sol.x]))
    if not np.all(np.isfinite(res)):
        raise EstimationFailed(
            f"record {record.run_id} predicted by the {setup.dof} equation with {', '.join(names)}",
            "the predicted motion did not stay finite",
        )
    return res


def _typical(records, setup: Setup, names, g0, inertia: float = 0.0) -> np.ndarray:
    """Each coefficient's natural size on these records: the one whose force equals the
    record's typical force (inertia × acceleration, or the drive). The inertia is the known
    one, else the identified one: its start in ``g0``, else ``inertia`` (a model's fitted
    value, when ``names`` are terms added to it). Without it a free decay whose whole
    inertia is identified has no force to size a candidate by, and every candidate's
    sensitivity vanished (issue 31: an 80 kg buoy's quadratic damping "not identified")."""
    if setup.inertia is not None:
        identified = float(setup.inertia)
    elif "inertia" in names:
        identified = float(g0[list(names).index("inertia")])
    else:
        identified = float(inertia)
    if len(names) == 0:
        return np.array([])
    per_record = []  # what each record gives every name: ξ, ẋ, ẍ, its force, max |ẍ|
    for r in records:
        t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
        v, a = derivatives(t, x)
        m = known_inertia_of(r, setup) + r.weight("inertia") * abs(identified)
        d = r.drive_at_samples()
        peak = float(np.max(np.abs(a)))
        force = max(m * peak, 0.0 if d is None else float(np.max(np.abs(d))))
        per_record.append((r, t, x - rest_of(r), v, a, force, peak))
    out = []
    for n, start in zip(names, g0, strict=True):
        sizes = []
        for r, t, xi, v, a, force, peak in per_record:
            size = (
                force / max(peak, 1e-12)
                if n == "inertia"
                else LIBRARY[n].typical(force, xi, v, a, r.hung_weight, t - t[0])
            )
            sizes.append(size / r.weight(n))
        out.append(max(max(sizes), abs(start) if np.isfinite(start) else 0.0, 1e-12))
    return np.array(out)


def simulate(
    records: Sequence[Record],
    setup: Setup,
    names: Sequence[str],
    values: np.ndarray,
    initial: np.ndarray | None = None,
    rows: slice = slice(None),
) -> list[tuple[np.ndarray, np.ndarray]]:
    """ξ and ξ̇ at each record's samples for fixed coefficients ``values`` (``names``, as
    ``names_of`` orders them; (S, ng): S sets at once, each result then (S, n)) from each
    record's initial state ``initial`` ((S,) R, 2: ξ₀, ξ̇₀; a record at rest ignores its
    own; None: every record at rest), on the one step the integrator chooses for all the
    sets; ``rows``: only the sets ``values[rows]`` on that step (a finite-difference
    Jacobian's perturbed sets after its centre: the same numbers as all at once)."""
    g = np.atleast_2d(np.asarray(values, dtype=float))
    nr = len(records)
    prob = _Problem(records, setup, names, np.ones(len(names) + nr + 2 * nr))
    if initial is None:
        initial = np.zeros((nr, 2))
    init = np.broadcast_to(np.asarray(initial, dtype=float), (g.shape[0], nr, 2))
    sims = prob.simulate(g, init[:, prob.free, 0], init[:, prob.free, 1], rows)
    if np.ndim(values) == 1:
        return [(x[0], v[0]) for x, v in sims]
    return sims


def at_step_limit(
    records: Sequence[Record], setup: Setup, names: Sequence[str], values: np.ndarray
) -> bool:
    """Whether the parameter sets ``values`` (S, ng) need the integrator's finest step or
    nearly (``equation.at_step_limit``): a fit there may rest on it, not on the data; never
    in the closed form (``constant_pull``), which has no step."""
    prob = _Problem(records, setup, names, np.ones(len(names) + 3 * len(records)))
    if prob.closed:
        return False
    inertia, coeffs, _ = prob.parts(np.atleast_2d(np.asarray(values, dtype=float)))
    forces = [c for c in coeffs if c.term.role == "force"]
    return equation.at_step_limit(prob.tracks, total_inertia(prob.tracks, inertia, coeffs), forces)


def step_of(
    records: Sequence[Record], setup: Setup, names: Sequence[str], values: np.ndarray
) -> tuple[float | None, np.ndarray]:
    """The integrator's step (s) for the parameter sets ``values`` (S, ng) on these records
    and which sets it cannot resolve (``equation.integration_step``); None: the closed form
    (``constant_pull``) applies, no step."""
    prob = _Problem(records, setup, names, np.ones(len(names) + 3 * len(records)))
    if prob.closed:
        return None, np.zeros(np.shape(values)[0], dtype=bool)
    return prob.step(np.atleast_2d(np.asarray(values, dtype=float)))


def sensitivities(
    records: Sequence[Record], setup: Setup, fit: MotionFit, extra: Sequence[str]
) -> tuple[np.ndarray, np.ndarray]:
    """∂x/∂θ at ``fit`` for its own parameters (n, p) and for each ``extra`` term added
    at zero (n, k): one vectorized integration."""
    names = (*fit.names, *extra)
    g = np.concatenate([fit.values, np.zeros(len(extra))])
    typical = np.concatenate(
        [
            np.maximum(np.abs(fit.values), 1e-12),
            _typical(
                records,
                setup,
                extra,
                np.zeros(len(extra)),
                fit.value("inertia") if "inertia" in fit.names else 0.0,
            ),
        ]
    )
    amp = max(float(np.ptp(np.asarray(r.x))) for r in records) or 1.0
    nuisances = len(records) + 2 * sum(r.free for r in records)
    prob = _Problem(records, setup, names, np.concatenate([typical, np.full(nuisances, amp)]))
    p = np.concatenate([g, parameters_of(fit)[len(fit.values) :]])
    jac = -prob.jacobian(p)
    k, ng = len(extra), len(fit.values)
    own = np.delete(jac, np.arange(ng, ng + k), axis=1)
    return own, jac[:, ng : ng + k]
