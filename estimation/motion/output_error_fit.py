"""Output-error fit of the one equation to records of one DOF, from any initial state.

Minimises Σ_records Σ_samples (x_meas − x_eq − ξ(t; θ, ξ₀, ξ̇₀))², where ξ solves

    (M_known + w_M·M + Σ θ_i·w_i)·ξ̈ = τ(t) + Σ_j w_j·θ_j·φ_j(ξ, ξ̇)          (equation.py)

from the state (ξ₀, ξ̇₀) at each record's first sample: the equilibrium x_eq (a spring is
anchored there, not at the release point) and the initial state are nuisance parameters
per record. Known terms (a hydrostatic stiffness) are fixed; M_known, the known terms and
the weights w of the identified coefficients may differ per record (``Record``: a
pendulum's geometry). σ from ``identify``, quantization included (a direction the data
cannot determine is reported, not dropped). Start values from the
equation-error least squares on Savitzky–Golay derivatives; every parameter is scaled by its
typical size, bounded by its term's bounds; the integrator's step resolves each trial's
period and damping rate (``equation.integration_step``), and a trial far from the data is a
large finite misfit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.errors import EstimationFailed
from estimation.motion.equation import Track, integrate
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

    equilibrium: np.ndarray  # per record, m or rad
    initial: np.ndarray  # (R, 2): ξ₀ (m or rad), ξ̇₀ (m/s or rad/s)
    displacements: tuple[np.ndarray, ...]  # model ξ at the samples
    velocities: tuple[np.ndarray, ...]  # model ξ̇ at the samples
    not_identified: tuple[str, ...] = ()


def names_of(setup: Setup, effects: Sequence[str]) -> tuple[str, ...]:
    """Fitted coefficient names: inertia (unless known), base terms, then effects."""
    head = ("inertia",) if setup.inertia is None else ()
    return (*head, *setup.terms, *effects)


def equation_error_start(records: Sequence[Record], setup: Setup, names: Sequence[str]):
    """Coefficients, equilibria and initial states from least squares on derivatives."""
    rows, rhs, eqs, init = [], [], [], []
    for r in records:
        t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
        v, a = derivatives(t, x)
        eq = float(np.median(x[-max(x.size // 5, 3) :]))
        xi = x - eq
        eqs.append(eq)
        init.append((xi[0], v[0]))
        drive = r.drive_at_samples()
        b = (np.zeros_like(t) if drive is None else drive) - known_inertia_of(r, setup) * a
        for n, value in known_terms_of(r, setup).items():
            b = b + value * LIBRARY[n].regressor(xi, v, a, 0.0, t - t[0])
        if setup.inertia is not None:
            b = b - setup.inertia * r.weight("inertia") * a
        cols = [
            r.weight(n) * (a if n == "inertia" else -LIBRARY[n].regressor(xi, v, a, 0.0, t - t[0]))
            for n in names
        ]
        rows.append(np.column_stack([*cols, np.ones_like(t)]))
        rhs.append(b)
    sol = np.linalg.lstsq(np.vstack(rows), np.concatenate(rhs), rcond=None)[0]
    return sol[: len(names)], np.array(eqs), np.array(init, dtype=float)


class _Problem:
    """Residuals and Jacobian of the joint fit (globals, then x_eq, ξ₀, ξ̇₀ per record)."""

    def __init__(
        self,
        records: Sequence[Record],
        setup: Setup,
        names: Sequence[str],
        scale: np.ndarray,
    ) -> None:
        self.scale = scale  # typical size of every parameter (globals, x_eq, ξ₀, ξ̇₀)
        self.setup, self.names = setup, tuple(names)
        self.ng, self.nr = len(self.names), len(records)
        self.tracks = []
        for r in records:
            t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
            self.tracks.append(
                Track(
                    t - t[0],
                    r.drive_at_samples(),
                    known_inertia_of(r, setup),
                    0.0,
                    float(np.ptp(x)) or 1.0,
                    reach=float(np.max(np.abs(x - np.median(x)))),
                    speed=float(np.max(np.abs(derivatives(t, x)[0]))),
                )
            )
        #: each identified coefficient's weight per record (ng, R); known terms per record
        self.weights = np.array([[r.weight(n) for r in records] for n in self.names])
        self.inertia_weight = np.array([r.weight("inertia") for r in records])
        known = dict.fromkeys(n for r in records for n in known_terms_of(r, setup))
        self.known = {
            n: np.array([known_terms_of(r, setup).get(n, 0.0) for r in records]) for n in known
        }
        self.sizes = [r.t.size for r in records]
        self.starts = np.concatenate([[0], np.cumsum(self.sizes)])
        self.measured = np.concatenate([np.asarray(r.x, dtype=float) for r in records])
        self.index = np.repeat(np.arange(self.nr), self.sizes)
        self._key: bytes | None = None

    def split(self, p: np.ndarray):
        ng, nr = self.ng, self.nr
        return p[:ng], p[ng : ng + nr], p[ng + nr : ng + 2 * nr], p[ng + 2 * nr :]

    def simulate(self, g: np.ndarray, xi0: np.ndarray, v0: np.ndarray):
        """Per record (ξ, ξ̇) at the samples for parameter sets g (S, ng)."""
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
        return integrate(self.tracks, inertia, coeffs, xi0, v0)

    def _evaluate(self, p: np.ndarray) -> None:
        key = p.tobytes()
        if key == self._key:
            return
        g, eq, xi0, v0 = self.split(p)
        self.g_steps = 1e-6 * np.maximum(np.abs(g), self.scale[: self.ng] * 1e-3)
        self.x_step = 1e-6 * np.maximum(np.abs(xi0), self.scale[self.ng + self.nr :][: self.nr])
        self.v_step = 1e-6 * np.maximum(np.abs(v0), self.scale[self.ng + 2 * self.nr :])
        sets = np.vstack([g, g + np.diag(self.g_steps), g, g])
        x0 = np.vstack([xi0] * (self.ng + 1) + [xi0 + self.x_step, xi0])
        vv = np.vstack([v0] * (self.ng + 2) + [v0 + self.v_step])
        sims = self.simulate(sets, x0, vv)
        self.x = np.concatenate([s[0] for s in sims], axis=1)
        self.v = np.concatenate([s[1] for s in sims], axis=1)
        self.model = self.x[0] + eq[self.index]
        self._key = key

    def residual(self, p: np.ndarray) -> np.ndarray:
        self._evaluate(p)
        return self.measured - self.model

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        self._evaluate(p)
        ng, nr, rows = self.ng, self.nr, np.arange(self.measured.size)
        jac = np.zeros((self.measured.size, p.size))
        jac[:, :ng] = -((self.x[1 : ng + 1] - self.x[0]) / self.g_steps[:, None]).T
        jac[rows, ng + self.index] = -1.0
        jac[rows, ng + nr + self.index] = -(self.x[ng + 1] - self.x[0]) / self.x_step[self.index]
        jac[rows, ng + 2 * nr + self.index] = (
            -(self.x[ng + 2] - self.x[0]) / self.v_step[self.index]
        )
        return jac


def _bounds(records: Sequence[Record], setup: Setup, names: Sequence[str], typical: np.ndarray):
    nr = len(records)
    lo, hi = [], []
    for n, s in zip(names, typical, strict=True):
        if n == "inertia":  # the total inertia stays positive on every record
            low = max(-known_inertia_of(r, setup) / r.weight("inertia") for r in records)
            lo.append(low + 1e-9 * max(s, -low))
            hi.append(np.inf)
        else:
            lo.append(LIBRARY[n].lower)
            hi.append(LIBRARY[n].upper)
    inf = [np.inf] * (3 * nr)
    return np.array(lo + [-np.inf] * (3 * nr)), np.array(hi + inf)


def _solve(
    records: Sequence[Record],
    setup: Setup,
    names: Sequence[str],
    start: np.ndarray | None,
    max_nfev: int,
    tolerance: float,
) -> tuple[_Problem, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The joint least squares (``fit_motion``): its problem, the solution (globals, x_eq,
    ξ₀, ξ̇₀), the bounds and each coefficient's typical size."""
    nr = len(records)
    g0, eq0, init0 = equation_error_start(records, setup, names)
    amp = max(float(np.ptp(np.asarray(r.x))) for r in records) or 1.0
    speed = max(float(np.ptp(derivatives(np.asarray(r.t), np.asarray(r.x))[0])) for r in records)
    typical = _typical(records, setup, names, g0)
    if start is not None:
        g0 = np.asarray(start, dtype=float)[: len(names)]
        eq0, xi0, v0 = np.split(np.asarray(start, dtype=float)[len(names) :], 3)
        init0 = np.column_stack([xi0, v0])
    lower, upper = _bounds(records, setup, names, typical)
    p0 = np.concatenate([g0, eq0, init0[:, 0], init0[:, 1]])
    nudge = np.concatenate([1e-6 * typical, np.zeros(3 * nr)])
    p0 = np.clip(np.where(np.isfinite(p0), p0, 0.0), lower, upper)
    p0 = np.where(np.isfinite(lower) & (p0 <= lower), lower + nudge, p0)
    scale = np.concatenate(
        [typical, np.full(nr, amp), np.full(nr, amp), np.full(nr, max(speed, 1e-12))]
    )
    prob = _Problem(records, setup, names, scale)
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


def fit_motion(
    records: Sequence[Record],
    setup: Setup,
    effects: Sequence[str] = (),
    start: np.ndarray | None = None,
    max_nfev: int = 100,
) -> MotionFit:
    """Fit the identified coefficients and each record's x_eq, ξ₀, ξ̇₀ (module doc).

    ``start``: full parameter vector of a previous fit (globals then nuisances) to go on
    from; new effects then start at their ``start_share`` of their typical size.
    """
    names = names_of(setup, effects)
    prob, p, lower, upper, typical = _solve(records, setup, names, start, max_nfev, FIT_TOLERANCE)
    res = prob.residual(p)
    if not np.all(np.isfinite(res)):
        raise EstimationFailed(
            f"the {setup.dof} equation with {', '.join(names)}",
            "the simulated motion did not stay finite from any start",
        )
    fitted, steps = prob.measured - res, [record_step(r.x) for r in records]
    stats = honest_statistics(res, prob.jacobian(p), len(names), prob.sizes, fitted, steps)
    tol = 1e-6 * np.maximum(np.abs(p[: len(names)]), typical * 1e-3)
    at_bound = tuple(
        n
        for n, v, lo, hi, e in zip(names, p, lower, upper, tol, strict=False)
        if abs(v - lo) < e or abs(v - hi) < e
    )
    g, eq, xi0, v0 = prob.split(p)
    prob._evaluate(p)
    return MotionFit(
        effects=tuple(effects),
        names=names,
        values=g.copy(),
        **stats.fit_fields(),
        residuals=tuple(np.split(res, prob.starts[1:-1])),
        at_bound=at_bound,
        equilibrium=eq.copy(),
        initial=np.column_stack([xi0, v0]),
        displacements=tuple(np.split(prob.x[0], prob.starts[1:-1])),
        velocities=tuple(np.split(prob.v[0], prob.starts[1:-1])),
        not_identified=tuple(
            n for n, lost in zip(names, stats.not_identified, strict=True) if lost
        ),
    )


def parameters_of(fit: MotionFit) -> np.ndarray:
    """The full parameter vector of ``fit`` (globals, x_eq, ξ₀, ξ̇₀) to restart from."""
    return np.concatenate([fit.values, fit.equilibrium, fit.initial[:, 0], fit.initial[:, 1]])


@dataclass(frozen=True)
class HeldOut:
    """A leave-one-record-out check: the pooled RMSE of the held-out records' predictions
    and each fold's (m or rad; in the records' order)."""

    rmse: float
    per_record: tuple[float, ...]


def leave_one_record_out(records: Sequence[Record], setup: Setup, fit: MotionFit) -> HeldOut | None:
    """Each record predicted by the shared coefficients refitted on the others (None with
    fewer than ``LORO_MIN_RUNS`` records).

    Per fold: ``fit``'s coefficients and the other records' nuisances are refitted from
    ``fit``'s optimum (``LORO_NFEV`` evaluations, ``REFIT_TOLERANCE``); the held-out record
    is then simulated with those coefficients fixed, fitting only its own x_eq, ξ₀, ξ̇₀
    (``predict_record``). Raises ``EstimationFailed`` when a refit or a prediction does
    not stay finite."""
    nr = len(records)
    if nr < LORO_MIN_RUNS:
        return None
    p, ng = parameters_of(fit), len(fit.names)
    held_out = []
    for i in range(nr):
        train = [r for j, r in enumerate(records) if j != i]
        start = np.delete(p, [ng + i, ng + nr + i, ng + 2 * nr + i])
        prob, sub, *_ = _solve(train, setup, fit.names, start, LORO_NFEV, REFIT_TOLERANCE)
        if not np.all(np.isfinite(prob.residual(sub))):
            raise EstimationFailed(
                f"the {setup.dof} equation with {', '.join(fit.names)} without record "
                f"{records[i].run_id}",
                "the refitted motion did not stay finite",
            )
        nuisance = np.array([fit.equilibrium[i], *fit.initial[i]])
        held_out.append(predict_record(records, i, setup, fit.names, sub[:ng], nuisance))
    per_record = tuple(float(np.sqrt(np.mean(r**2))) for r in held_out)
    return HeldOut(pooled_rmse(held_out), per_record)


def predict_record(
    records: Sequence[Record],
    index: int,
    setup: Setup,
    names: Sequence[str],
    values: np.ndarray,
    nuisance: np.ndarray,
) -> np.ndarray:
    """Residual of ``records[index]`` under fixed coefficients ``values`` (``names``),
    fitting only its own x_eq, ξ₀, ξ̇₀ (``nuisance``: their start) to ``REFIT_TOLERANCE``."""
    record, ng = records[index], len(names)
    amp = float(np.ptp(np.asarray(record.x))) or 1.0
    speed = float(np.ptp(derivatives(np.asarray(record.t), np.asarray(record.x))[0]))
    scale = np.concatenate([np.maximum(np.abs(values), 1e-12), [amp, amp, max(speed, 1e-12)]])
    prob = _Problem([record], setup, names, scale)
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
    out = []
    for n, start in zip(names, g0, strict=True):
        sizes = []
        for r in records:
            t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
            v, a = derivatives(t, x)
            xi = x - np.median(x[-max(x.size // 5, 3) :])
            m = known_inertia_of(r, setup) + r.weight("inertia") * abs(identified)
            d = r.drive_at_samples()
            force = max(
                m * float(np.max(np.abs(a))), 0.0 if d is None else float(np.max(np.abs(d)))
            )
            size = (
                force / max(float(np.max(np.abs(a))), 1e-12)
                if n == "inertia"
                else LIBRARY[n].typical(force, xi, v, a, 0.0, t - t[0])
            )
            sizes.append(size / r.weight(n))
        out.append(max(max(sizes), abs(start) if np.isfinite(start) else 0.0, 1e-12))
    return np.array(out)


def simulate(
    records: Sequence[Record],
    setup: Setup,
    names: Sequence[str],
    values: np.ndarray,
    initial: np.ndarray,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """ξ and ξ̇ at each record's samples for fixed coefficients ``values`` (``names``, as
    ``names_of`` orders them; (S, ng): S sets at once, each result then (S, n)) from each
    record's initial state ``initial`` ((S,) R, 2: ξ₀, ξ̇₀), on the one step the
    integrator chooses for all the sets."""
    g = np.atleast_2d(np.asarray(values, dtype=float))
    prob = _Problem(records, setup, names, np.ones(len(names) + 3 * len(records)))
    init = np.broadcast_to(np.asarray(initial, dtype=float), (g.shape[0], len(records), 2))
    sims = prob.simulate(g, init[:, :, 0], init[:, :, 1])
    if np.ndim(values) == 1:
        return [(x[0], v[0]) for x, v in sims]
    return sims


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
    nr = len(records)
    scale = np.concatenate([typical, np.full(2 * nr, amp), np.full(nr, amp)])
    prob = _Problem(records, setup, names, scale)
    p = np.concatenate([g, fit.equilibrium, fit.initial[:, 0], fit.initial[:, 1]])
    jac = -prob.jacobian(p)
    k, ng = len(extra), len(fit.values)
    own = np.delete(jac, np.arange(ng, ng + k), axis=1)
    return own, jac[:, ng : ng + k]
