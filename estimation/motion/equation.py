"""The one single-DOF equation of motion, integrated from any initial state: every record
kind's simulator (free decays and pendulums from a fitted state, tows and spins from rest at
their release, ``axis.model``).

    (M + M_known + Σ_i θ_i·w_i)·ẍ = τ(t) + Σ_j θ_j·φ_j(x, ẋ) + Σ_l θ_l·φ_l(t)   (terms.py)

(M and each θ_j per parameter set and record: a coefficient weighted per record is
passed as its product with the weight.)

x in m or rad from the equilibrium, τ in N or N·m: constant, held per sample (zero-order
hold: each step takes the drive's exact mean over its span) or absent (a free decay). A
term of time (φ_l(t), t from the record's first sample) joins the drive at each step's
middle (the exact mean over the step of a linear one).
Parameter sets are rows (S) and records columns (R) of every array, so a finite-difference
Jacobian costs one vectorized integration. RK4 on one fixed step per integration, chosen
for the sets it integrates (``integration_step``: the sample period of a held drive, else
0.1 s, refined to resolve every set's period and damping rate; a set whose motion settles
within 1/8 of a sample is not integrated); the state at the samples is read off the step
grid by cubic Hermite interpolation. The step loop runs compiled
(``kernel.step_grid``: the same arithmetic, 10–25× less CPU), and so does the read-off of a
grid it made (``kernel.hermite``: the same numbers, 5× less CPU); a term whose regressor has no
compiled form, and a process's first few short grids (``kernel.LOOP``: loading the
compiled loop costs more than they do), step in NumPy here (``_numpy_grid``), with the same
result.

Dry friction (a set-valued term) is integrated exactly as the pendulum's own simulator did:
within a step its force is constant, −F_c·sign of the motion at the step's start; a step in
which the velocity reverses is split at the reversal (found by one Newton step), where the
body sticks while the other forces stay within F_c, else goes on the other way. Stepping
over a reversal with RK4 instead costs O(h²·2F_c/M) per reversal: on a lightly damped
pendulum (tests/estimation/pendulum/test_pendulum.py) 30× the sample noise and a 2.5 % bias in F_c.

A record starts at τ = 0 (``Track``): a free record at its first fitted sample, from the
state the caller gives; a tow at its release, from rest, with its samples before it held
there. A parameter set may start later (``shift``: a tow's fitted release delay), with the
drive read from its own start.

Overflow is stopped where it starts: a trial parameter set whose state leaves
``STATE_LIMIT`` × the record's own range is frozen there (its misfit is then large and
finite), so no inf or NaN reaches a fit; a set the caller's step cannot resolve
(``unresolved``) is not integrated and sits at that limit from the start.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from estimation.motion.kernel import LOOP, step_grid
from estimation.motion.kernel import hermite as kernel_hermite
from estimation.motion.terms import Regressor, Term, TermValues

#: A trajectory beyond this multiple of the record's range is a diverged trial: frozen.
STATE_LIMIT = 1e3
#: RK4 steps per natural period: the phase error is ≈ (ωh)⁴/120 per radian of motion,
#: 1.0e-6 at 60 steps: over the 30 rad of a 40 s pendulum decay released from 0.25 rad,
#: 8e-6 rad against the record's 2e-5 rad noise (24 steps: 1.9e-5 rad, the noise itself;
#: tests/estimation/pendulum/test_pendulum.py checks the match to solve_ivp within 1e-5 rad).
STEPS_PER_PERIOD = 60
#: Steps between two checks for a diverged trial (RK4 cannot overflow from the limit in
#: fewer unless h·|λ| > 10⁴⁰ᐟ⁸; a non-finite state met later is frozen all the same).
GUARD_EVERY = 8
#: Steps per damping time constant M/c: h·c/M ≤ 0.25, RK4's local error (h·c/M)⁵/120 ≈ 8e-6
#: of the transient per step and far inside its stability limit (h·c/M ≈ 2.785). A heavily
#: damped tow integrated so stays within 1e-6 m of solve_ivp over 1.9 m at 10–1000 kg
#: (tests/estimation/tow/test_axis_numerics.py); at h·c/M = 0.5 the 10 kg one was 2.7e-6 m
#: off. (The tows' step used to be a power-of-two fraction of the sample period at 0.5,
#: which landed between 0.25 and 0.5.)
DAMPING_STEP = 0.25
#: The coarsest step where no period or damping limits it (s): RK4's error < 1e-6 m on
#: BENBAM-like tows (time constants ≥ 0.5 s).
MAX_STEP_S = 0.1
#: A damping time constant M/c under 1/``SETTLES_WITHIN`` of a sample is one no sampled
#: record resolves: the motion settles within it. The finest step is the one such a set
#: needs, ``DAMPING_STEP``/``SETTLES_WITHIN`` of a sample (``integration_step``); a period
#: that needs it spans under 2 samples. (A floor 4× finer left the ship2d fit on the limit
#: as well, at 4× the time.)
SETTLES_WITHIN = 8


def _constant(term: Term) -> bool:
    """A regressor that depends on neither x nor ẋ (a bias): one value for a whole run."""
    return term.x_power is None and term.v_power in (None, 0) and not term.sign_of_v


def accelerator(
    forces: Sequence[TermValues], inv_inertia: np.ndarray, shape: tuple[int, ...]
) -> Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """ẍ of the equation as a function of (x, v, drive) on states of ``shape``, for fixed
    single-valued ``forces`` (dry friction is stepped apart: ``_friction_step``): the terms'
    lookups and the constant regressors' forces are done once, not in each of the
    integrator's four stages per step (the sum keeps its order and its values)."""
    parts: list[tuple[np.ndarray, Regressor | None]] = []
    zero = np.zeros(shape)
    for c in forces:
        if _constant(c.term):
            parts.append((c.value * c.term.phi(zero, zero), None))
        else:
            parts.append((c.value, c.term.phi))

    def accel(x: np.ndarray, v: np.ndarray, drive: np.ndarray) -> np.ndarray:
        net = drive
        for value, phi in parts:
            net = net + (value if phi is None else value * phi(x, v))
        return net * inv_inertia

    return accel


def hermite(
    grid_x: np.ndarray, grid_v: np.ndarray, h: float, tau: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Cubic Hermite interpolation on a uniform grid; grid arrays (K, S), tau (S, n) or
    (1, n): the same times for every set. Returns x and ẋ, each (S, n)."""
    k_max = grid_x.shape[0] - 2
    k = np.clip(np.floor(tau / h).astype(int), 0, k_max)
    s = np.clip(tau / h - k, 0.0, 1.0)
    cols = np.arange(grid_x.shape[1])[:, None]
    x0, x1 = grid_x[k, cols], grid_x[k + 1, cols]
    v0, v1 = grid_v[k, cols] * h, grid_v[k + 1, cols] * h
    s2, s3 = s * s, s * s * s
    x = (2 * s3 - 3 * s2 + 1) * x0 + (s3 - 2 * s2 + s) * v0 + (-2 * s3 + 3 * s2) * x1
    x = x + (s3 - s2) * v1
    v = ((6 * s2 - 6 * s) * x0 + (3 * s2 - 4 * s + 1) * v0 + (6 * s - 6 * s2) * x1) / h
    v = v + (3 * s2 - 2 * s) * v1 / h
    return x, v


def _force(
    x: np.ndarray, v: np.ndarray, drive: np.ndarray, smooth: Sequence[TermValues]
) -> np.ndarray:
    """The drive plus every single-valued term's force at (x, v) (N or N·m)."""
    net = drive
    for c in smooth:
        net = net + c.value * c.term.phi(x, v)
    return net


def _rk4_held(
    x: np.ndarray,
    v: np.ndarray,
    drive: np.ndarray,
    inv: np.ndarray,
    smooth: Sequence[TermValues],
    friction: np.ndarray,
    h: float | np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One RK4 step of length ``h`` (scalar or per entry) with the dry friction's force held
    at ``friction`` (−F_c·direction) through the step."""
    half = 0.5 * h
    a1 = (_force(x, v, drive, smooth) + friction) * inv
    v2 = v + half * a1
    a2 = (_force(x + half * v, v2, drive, smooth) + friction) * inv
    v3 = v + half * a2
    a3 = (_force(x + half * v2, v3, drive, smooth) + friction) * inv
    a4 = (_force(x + h * v3, v + h * a3, drive, smooth) + friction) * inv
    return x + h * v + h * h / 6.0 * (a1 + a2 + a3), v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)


def _friction_step(
    x: np.ndarray,
    v: np.ndarray,
    drive: np.ndarray,
    inv: np.ndarray,
    smooth: Sequence[TermValues],
    held: np.ndarray,
    h: float,
) -> tuple[np.ndarray, np.ndarray]:
    """One step with dry friction of size ``held`` (module doc): stuck, moving, or split
    at a reversal of the velocity."""
    zero = np.zeros_like(v)
    still = v == 0.0
    pull = _force(x, zero, drive, smooth)
    stuck = still & (np.abs(pull) <= held)
    direction = np.where(stuck, 0.0, np.where(still, np.sign(pull), np.sign(v)))
    x1, v1 = _rk4_held(x, v, drive, inv, smooth, -held * direction, h)
    # split at every reversal, also at F_c = 0: a fit's finite differences then compare
    # trajectories integrated on the same steps
    turned = ~stuck & (v1 * direction < 0)
    if turned.any():
        h1 = h * np.clip(np.abs(v) / np.maximum(np.abs(v) + np.abs(v1), 1e-300), 0.0, 1.0)
        xa, va = _rk4_held(x, v, drive, inv, smooth, -held * direction, h1)
        aa = (_force(xa, va, drive, smooth) - held * direction) * inv
        h1 = np.clip(h1 - va / np.where(aa == 0, np.inf, aa), 0.0, h)
        xa, _ = _rk4_held(x, v, drive, inv, smooth, -held * direction, h1)
        pull = _force(xa, zero, drive, smooth)
        sticks = np.abs(pull) <= held
        xb, vb = _rk4_held(xa, zero, drive, inv, smooth, -held * np.sign(pull), h - h1)
        x1 = np.where(turned, np.where(sticks, xa, xb), x1)
        v1 = np.where(turned, np.where(sticks, 0.0, vb), v1)
    return np.where(stuck, x, x1), np.where(stuck, 0.0, v1)


@dataclass(frozen=True)
class Track:
    """One record as the integrator reads it: sample times from its start, the drive held
    per sample (None: free), the known inertia and the inertia terms' weight.

    The start is τ = 0: a free record's first fitted sample, a tow's release (its samples
    before it have τ < 0 and read the state at the start: held at rest)."""

    tau: np.ndarray  # s, from the start (0)
    drive: np.ndarray | None  # N or N·m per sample (zero-order hold), None: no drive
    known_inertia: float = 0.0
    weight: float = 0.0
    scale: float = 1.0  # the record's own range of x (m or rad): the divergence guard
    #: The drive held before the first sample (N or N·m; None: the first sample's).
    drive_before: float | None = None
    #: The record's largest excursion (m or rad) and speed (m/s or rad/s): where the step
    #: linearises the forces (``integration_step``).
    reach: float = 0.0
    speed: float = 0.0

    # A fit integrates its tracks hundreds of times: what depends on the track alone is
    # computed on the first integration and kept (the arrays are never written to).
    @cached_property
    def sample_interval(self) -> float | None:
        """The median sample interval (s); None with fewer than two samples."""
        return float(np.median(np.diff(self.tau))) if self.tau.size > 1 else None

    @cached_property
    def varying_drive(self) -> bool:
        """Whether the drive changes from sample to sample (not absent or constant)."""
        return self.drive is not None and bool(np.ptp(self.drive) > 0)

    @cached_property
    def drive_integral(self) -> np.ndarray:
        """The held drive's integral from the first sample to each sample (N·s or N·m·s)."""
        assert self.drive is not None
        return np.concatenate([[0.0], np.cumsum(self.drive[:-1] * np.diff(self.tau))])


def _mean_drive(track: Track, edges: np.ndarray, h: float) -> np.ndarray:
    """The held drive's mean over each step between consecutive ``edges`` (τ, s; steps along
    the first axis): ``drive_before`` before the first sample, the last value beyond it."""
    assert track.drive is not None
    t, f = track.tau, track.drive
    j = np.clip(np.searchsorted(t, edges, side="right") - 1, 0, t.size - 1)
    at = track.drive_integral[j] + f[j] * (edges - t[j])
    if track.drive_before is not None:
        at = np.where(edges < t[0], track.drive_before * (edges - t[0]), at)
    return np.diff(at, axis=0) / h


def range_rates(
    terms: Sequence[tuple[Term, np.ndarray | float]], reach: float, speed: float
) -> tuple[np.ndarray, np.ndarray]:
    """The largest stiffness −Σ θ·∂φ/∂x and damping −Σ θ·∂φ/∂ẋ of ``terms`` (entry,
    coefficient: a number, or one per parameter set) over x ∈ {0, ±reach}, ẋ ∈ {0, ±speed}:
    each term's rate at the record's range (a quadratic damping's 2·B₂·|ẋ|, a cubic
    stiffness's 3·k₃·x²), per parameter set (the trailing axis reduced)."""
    stiffness = np.zeros(9)
    damping = np.zeros(9)
    for term, value in terms:
        theta = np.asarray(value, dtype=float)[..., None]
        dphi_dx, dphi_dv = _rates_at_range(term, reach, speed)
        stiffness = stiffness - theta * dphi_dx
        damping = damping - theta * dphi_dv
    return stiffness.max(axis=-1), damping.max(axis=-1)


@lru_cache(maxsize=256)
def _rates_at_range(term: Term, reach: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """∂φ/∂x and ∂φ/∂ẋ of ``term`` at the 9 states of ``range_rates`` (read-only: shared)."""
    xs, vs = (a.ravel() for a in np.meshgrid([0.0, reach, -reach], [0.0, speed, -speed]))
    rates = (
        np.broadcast_to(term.dphi_dx(xs, vs), xs.shape),
        np.broadcast_to(term.dphi_dv(xs, vs), xs.shape),
    )
    for a in rates:
        a.flags.writeable = False
    return rates


def stable_step(inertia: np.ndarray, stiffness: np.ndarray, damping: np.ndarray) -> np.ndarray:
    """The largest step that resolves the natural period (``STEPS_PER_PERIOD`` steps) and the
    damping's rate (h ≤ ``DAMPING_STEP``·M/c) of each parameter set (s; arrays broadcast):
    inf where neither limits it, NaN for a set with a non-finite inertia or rate."""
    m, k, c = np.broadcast_arrays(
        *(np.asarray(a, dtype=float) for a in (inertia, stiffness, damping))
    )
    h = np.full(m.shape, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(
            (k > 0) & (m > 0), np.minimum(h, 2 * np.pi * np.sqrt(m / k) / STEPS_PER_PERIOD), h
        )
        h = np.where((c > 0) & (m > 0), np.minimum(h, DAMPING_STEP * m / c), h)
    return np.where(np.isfinite(m) & np.isfinite(k) & np.isfinite(c), h, np.nan)


def sample_step(tracks: Sequence[Track]) -> float:
    """The records' finest median sample interval (s; ``MAX_STEP_S`` without two samples)."""
    steps = [tr.sample_interval for tr in tracks if tr.sample_interval is not None]
    return min(steps, default=MAX_STEP_S)


def finest_step(tracks: Sequence[Track]) -> float:
    """The finest step ``integration_step`` takes (s): ``DAMPING_STEP``/``SETTLES_WITHIN``
    of a sample."""
    return DAMPING_STEP * sample_step(tracks) / SETTLES_WITHIN


def integration_step(
    tracks: Sequence[Track], inertia: np.ndarray, forces: Sequence[TermValues]
) -> tuple[float, np.ndarray]:
    """The RK4 step (s) for S parameter sets on R records, and which sets it cannot resolve
    (bool, (S,)): every integration's, chosen for the sets it integrates.

    The coarsest step is a per-sample drive's sample interval (one step per held value),
    else ``MAX_STEP_S`` (or 10 samples, if fewer). Below it, the largest step that resolves
    every set's natural period and damping rate on every record (``stable_step`` on the
    forces linearised over the record's reach and speed, ``range_rates``). A set that
    needs a finer step than ``finest_step`` settles within 1/``SETTLES_WITHIN`` of a sample,
    which no sampled record resolves: it is not integrated (a diverged trial, far from the data),
    never with an unstable step. ``inertia`` (S, R) is each set's total inertia; the
    forces' values broadcast to (S, R)."""
    n_sets, n_tracks = inertia.shape
    dt = sample_step(tracks)
    per_sample = any(tr.varying_drive for tr in tracks)
    base = dt if per_sample else min(MAX_STEP_S, 10 * dt)
    needed = np.full(n_sets, base)
    for i, tr in enumerate(tracks):
        rates = [(c.term, np.broadcast_to(c.value, (n_sets, n_tracks))[:, i]) for c in forces]
        stiffness, damping = range_rates(rates, tr.reach, tr.speed)
        needed = np.minimum(needed, stable_step(inertia[:, i], stiffness, damping))
    unresolved = ~(needed >= finest_step(tracks))  # a set of NaN too
    return float(np.min(needed[~unresolved], initial=base)), unresolved


def at_step_limit(
    tracks: Sequence[Track], inertia: np.ndarray, forces: Sequence[TermValues]
) -> bool:
    """Whether the sets need a step within 2× of the finest ``integration_step`` resolves:
    a fit there may rest on that limit, not on the data."""
    h, unresolved = integration_step(tracks, inertia, forces)
    return bool(unresolved.any()) or h < 2 * finest_step(tracks)


def total_inertia(
    tracks: Sequence[Track], inertia: np.ndarray, coefficients: Sequence[TermValues]
) -> np.ndarray:
    """M + M_known + Σ θ_i·w of the inertia terms, per set and track (S, R; kg or kg·m²):
    ``inertia`` (S,) or (S, R) the identified part."""
    n_sets = np.shape(inertia)[0]
    inertia = np.broadcast_to(np.reshape(inertia, (n_sets, -1)), (n_sets, len(tracks)))
    total = np.empty((n_sets, len(tracks)))
    for i, tr in enumerate(tracks):
        total[:, i] = inertia[:, i] + tr.known_inertia
        for c in coefficients:
            if c.term.role == "inertia":
                total[:, i] += c.value[:, min(i, c.value.shape[1] - 1)] * tr.weight
    return total


def integrate(
    tracks: Sequence[Track],
    inertia: np.ndarray,
    coefficients: Sequence[TermValues],
    x0: np.ndarray,
    v0: np.ndarray,
    h: float | None = None,
    *,
    shift: np.ndarray | None = None,
    unresolved: np.ndarray | None = None,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """x and ẋ at each track's samples, per parameter set: a list of (S, n) pairs.

    ``inertia`` (S,) or (S, R) is M; ``x0``/``v0`` (S, R) the state at each track's start.
    ``h``: the RK4 step (s); None: ``integration_step``'s for these sets. A set it cannot
    resolve (``unresolved`` (S,) with a given ``h``: the caller chose the step for more sets
    than it integrates, a finite-difference Jacobian's centre before its perturbations) is
    not integrated but held at the divergence limit at every sample (a diverged trial).
    ``shift`` (S,): each set's start later by this much (s; a tow's fitted release delay):
    its drive is read from there and its samples before it read the start state.
    """
    n_sets, n_tracks = x0.shape
    later = np.zeros(1) if shift is None else np.asarray(shift, dtype=float)
    forces = [c for c in coefficients if c.term.role == "force"]
    smooth = [c for c in forces if not c.term.set_valued_at_rest]
    held = None
    for c in forces:
        if c.term.set_valued_at_rest:
            held = c.value if held is None else held + c.value
    total = total_inertia(tracks, inertia, coefficients)
    if h is None:
        h, unresolved = integration_step(tracks, total, forces)
    span = max(float(tr.tau[-1]) for tr in tracks) - min(0.0, float(later.min()))
    n_steps = max(int(np.ceil(span / h)) + 2, 3)
    skipped = np.zeros(n_sets, dtype=bool) if unresolved is None else np.asarray(unresolved)
    inv = 1.0 / np.maximum(total, 1e-300)
    inv[skipped] = 0.0  # not integrated: their grid is overwritten below
    limit = np.array([STATE_LIMIT * max(tr.scale, 1e-12) for tr in tracks])
    # the step edges on each set's own time (K, S or 1): the drive and the forces of time
    edges = (np.arange(n_steps) * h)[:, None] + later[None, :]
    drive = np.zeros((n_steps - 1, edges.shape[1], n_tracks))
    for i, tr in enumerate(tracks):
        if tr.drive is not None:
            drive[:, :, i] = _mean_drive(tr, edges, h)
    middles = 0.5 * (edges[1:] + edges[:-1])
    zeros = np.zeros_like(middles)
    for c in coefficients:
        if c.term.role == "time":  # a force of time: its value at the step's middle (the
            # exact mean of a linear one), like the held drive's mean over the step
            ramp = c.term.regressor(zeros, zeros, zeros, 0.0, middles)
            drive = drive + np.asarray(c.value)[None, :, :] * ramp[:, :, None]
    chosen = LOOP.compiled(n_steps)
    compiled = (
        step_grid(x0, v0, drive, inv, forces, h, n_steps, limit, GUARD_EVERY) if chosen else None
    )
    if compiled is not None:
        xs, vs, frozen_any = compiled
    else:
        xs, vs, frozen_any = _numpy_grid(
            x0, v0, drive, inv, forces, smooth, held, h, n_steps, limit
        )
        if not chosen:  # a grid with a term of no compiled form is not the choice's
            LOOP.stepped_in_numpy(n_steps)
    if skipped.any():
        xs[:, skipped, :], vs[:, skipped, :] = limit, 0.0
    if frozen_any:  # the steps before the guard saw it: x and ẋ both held within the
        # limit's own scale (|ẋ| ≤ limit/h), else the Hermite read-off carries a velocity of
        # 1e90 (a softening restoring escapes in finite time, within GUARD_EVERY steps) into
        # the misfit and the fit's trust region overflows
        xs = np.clip(np.nan_to_num(xs), -limit, limit)
        vs = np.clip(np.nan_to_num(vs), -limit / h, limit / h)
    # a compiled grid is read off compiled too (the same numbers, a fifth of the time)
    read = hermite if compiled is None else kernel_hermite
    out = []
    for i, tr in enumerate(tracks):
        # held at the start before it; one row when every set starts at once (``hermite``
        # forms its weights once for all sets)
        tau = np.maximum(tr.tau[None, :] - later[:, None], 0.0)
        out.append(read(xs[:, :, i], vs[:, :, i], h, tau))
    return out


def _numpy_grid(x0, v0, drive, inv, forces, smooth, held, h, n_steps, limit):
    """``integrate``'s step grid in NumPy, for terms the compiled loop has no form for and
    for a process's first short grids (``kernel.py``): the same steps and guard."""
    n_sets, n_tracks = x0.shape
    xs = np.empty((n_steps, n_sets, n_tracks))
    vs = np.empty((n_steps, n_sets, n_tracks))
    x, v = x0.astype(float).copy(), v0.astype(float).copy()
    xs[0], vs[0] = x, v
    frozen = np.zeros_like(x, dtype=bool)
    half = 0.5 * h
    accel = accelerator(smooth, inv, x.shape)
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(1, n_steps):
            f = drive[k - 1]
            if held is not None:
                x, v = _friction_step(x, v, f, inv, smooth, np.abs(held), h)
                x, v = np.broadcast_arrays(x, v)
            else:
                a1 = accel(x, v, f)
                v2 = v + half * a1  # each stage's velocity, computed once (also its position)
                a2 = accel(x + half * v, v2, f)
                v3 = v + half * a2
                a3 = accel(x + half * v2, v3, f)
                a4 = accel(x + h * v3, v + h * a3, f)
                x = x + h * v + h * h / 6.0 * (a1 + a2 + a3)
                v = v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
            if k % GUARD_EVERY == 0 or k == n_steps - 1:
                bad = ~(np.isfinite(x) & np.isfinite(v) & (np.abs(x) < limit))
                if bad.any():  # a diverged trial: held at the limit from here on
                    frozen |= bad
                    x = np.where(frozen, np.clip(np.nan_to_num(x), -limit, limit), x)
                    v = np.where(frozen, 0.0, v)
            xs[k], vs[k] = x, v
    return xs, vs, bool(frozen.any())
