"""A release found in the data, refined by the axis model itself (the window of a
recording is found in :mod:`estimation.data.window`; this needs the model, so it lives
beside it)."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.data.run_arrays import RunData
from estimation.data.window import encoder_quantum, noise_threshold
from estimation.stats.misfit import ar1_inflation

#: Releases found in the data (not recorded) that the fit itself refines.
FOUND_RELEASES = ("release coil", "motion onset")
#: Half-width searched around a release found from the motion, s.
ONSET_SEARCH_S = 0.15
#: Step of the RMSE profile whose curvature gives a fitted release's σ, s.
PROFILE_STEP_S = 0.001


def fit_release(run: RunData) -> RunData:
    """A found release refined by the axis model itself: the instant within the coil's
    bracket (or ±ONSET_SEARCH_S around the motion onset) that minimises the run's
    output-error RMSE over a fixed set of samples. Recorded or given releases are kept."""
    found = run.window_found
    if found is None or found.release_source not in FOUND_RELEASES:
        return run
    t = np.asarray(run.t, dtype=float)
    if found.release_source == "release coil":
        before = t[t <= found.t_release]
        after = t[t > found.t_release]
        low = float(before[-1]) if before.size else float(t[0])
        high = float(after[0]) if after.size else found.t_release
    else:
        low = max(float(t[0]), found.t_release - ONSET_SEARCH_S)
        high = min(found.t_release + ONSET_SEARCH_S, first_moved(run, found.t_release))
    base = prepare(replace(run, t_release=low))
    if base.t.size < 8 or not high > low:
        return run
    first = fit_output_error([replace(base, t_release=found.t_release)], quantization_sigma=False)
    if not np.all(np.isfinite(first.values)):
        return run

    @cache  # the search's best instant is fitted again for the profile below: once is enough
    def rmse(instant: float) -> float:
        fit = fit_output_error(
            [replace(base, t_release=instant)], start=first.values, quantization_sigma=False
        )
        return float(fit.rmse) if np.isfinite(fit.rmse) else np.inf

    from scipy.optimize import minimize_scalar  # here: the service imports this module

    best = minimize_scalar(rmse, bounds=(low, high), method="bounded", options={"xatol": 1e-4})
    instant = float(best.x) if best.success and best.fun <= rmse(found.t_release) else None
    if instant is None:
        return run
    # how sharply the data fix it: the RMSE profile's curvature (ΔSSE = σ̂² at 1σ)
    n, h = base.t.size, PROFILE_STEP_S
    sse = [n * rmse(instant + d) ** 2 for d in (-h, 0.0, h)]
    curvature = (sse[0] - 2 * sse[1] + sse[2]) / h**2
    noise = sse[1] / max(n - 4, 1)
    std = float(np.sqrt(2 * noise / curvature)) if curvature > 0 else run.t_release_std
    report = replace(
        found,
        t_release=instant,
        release_source=f"{found.release_source}, refined by the fit",
        dropped_before=int(np.count_nonzero(t <= instant)),
    )
    return replace(
        run, t_release=instant, t_release_std=min(std, run.t_release_std), window_found=report
    )


def first_moved(run: RunData, t_release: float) -> float:
    """When the record first shows the body moved after ``t_release``: the time of the first
    sample beyond the motion threshold (``window.noise_threshold``) from the samples before
    it (the first sample when none), inf when none. A release refined by the fit stays
    before it: the body cannot have moved before its release (ten Cate E1's onset, refined
    0.155 s after its first sample, put a sample 3.4 mm along at rest)."""
    t = np.asarray(run.t, dtype=float)
    x = np.asarray(run.position, dtype=float)
    held = x[t <= t_release]
    base = float(np.median(held)) if held.size else float(x[0])
    after = np.nonzero((t > t_release) & (np.abs(x - base) > noise_threshold(x)))[0]
    return float(t[after[0]]) if after.size else np.inf


#: Samples after the release the start-at-rest check fits a parabola to (at most) …
REST_CHECK_SAMPLES = 7
#: … those whose mean speed since the release is below this share of the run's largest
#: speed (a start from rest is a parabola only while its speed is well below the top) …
REST_CHECK_SPAN_SHARE = 0.3
#: … and at least this many (three coefficients and one degree of freedom).
REST_CHECK_MIN_SAMPLES = 4
#: |v(release)| beyond this many σ of the local fit, and …
REST_CHECK_SIGMAS = 3.0
#: … beyond this share of the run's largest speed, is motion at the release.
REST_CHECK_SHARE = 0.05
#: Fewer samples in the span: the three samples' parabola gives the speed at the release
#: while the second step's mean speed is below this share of the top, …
REST_CHECK_EXTEND_SHARE = 0.5
#: … else moving only if the first step's mean speed is this share of the second's (from
#: rest ≈ 0.4–0.6 when the first step spans the acceleration; a body already at speed ≈ 1).
REST_CHECK_STEADY = 0.8
#: The residual's lag-1 autocorrelation counted at most this in the slope's σ (an
#: inflation of 199: beyond it a smooth residual would hide any speed at the release).
REST_CHECK_MAX_SERIAL = 0.99


def rest_before_release(run: RunData) -> bool:
    """Whether the record shows the body at rest shortly before its release: a sample
    before it, no more than ``REST_CHECK_SAMPLES`` median steps before, still within the
    motion threshold (``window.noise_threshold``) of the record's first sample. The start
    from rest is then in the record: a speed at the logged release is the log lagging the
    motion (or a sparse record stepping over the start), not a record that begins after
    its release."""
    t = np.asarray(run.t, dtype=float)
    x = np.asarray(run.position, dtype=float)
    before = np.nonzero(t < run.t_release)[0]
    if before.size == 0 or t.size < 2:
        return False
    threshold = noise_threshold(x[before]) if before.size >= 3 else encoder_quantum(x)
    still = before[np.abs(x[before] - x[before[0]]) <= max(threshold, 1e-12)]
    step = float(np.median(np.diff(t)))
    return bool(still.size) and run.t_release - t[still[-1]] <= REST_CHECK_SAMPLES * step


def speed_at_release(run: RunData, serial: float = 0.0) -> float | None:
    """The speed at the release (m/s or rad/s) when the data show the body already moving
    there, else None. A tow or spin starts from rest: x − x₀ = c·τ² near the release.

    Rules, in order:

    1. A record that shows the body at rest shortly before the release
       (``rest_before_release``) is not a moving start: the motion began in the record, so
       a speed at the logged release is a lag (a drive 0.15 s ahead of its log read
       0.03–0.1 m/s at 143 kg), for the fitted release and ``release_delay`` to take.
    2. A parabola x = a + b·τ + c·τ² is fitted to the samples after the release while their
       mean speed since it stays below REST_CHECK_SPAN_SHARE of the run's largest speed (at
       most ``REST_CHECK_SAMPLES``): beyond that the start is no parabola, and on a sparse
       record seven samples spanned the whole acceleration, their parabola's b read as a
       speed (24-point tows from rest called moving in 11 of 12 runs). b beyond
       REST_CHECK_SIGMAS σ and REST_CHECK_SHARE of the run's largest speed, the way the run
       goes, means the record starts after the release (already moving).
       A record that begins after its release (the release before its first sample) has
       no start in it to bound: its first ``REST_CHECK_SAMPLES`` are read whatever their
       spacing (ten Cate E1, 24 points, first 0.084 s after the release: 0.031 m/s of its
       0.034 m/s terminal speed, called moving).
    3. Fewer than ``REST_CHECK_MIN_SAMPLES`` in that span: the release sample and the two
       after it decide (``_three_sample_speed``): their parabola's slope while the second
       step is still well within the acceleration, else (the steps span it) the first
       step's mean speed against the second's.

    On 10, 143 and 1000 kg tows (``tests/estimation/term_cases``): 24-point irregular
    records from rest called moving in 0 of 144 runs (136 before these rules); records cut
    0.1–1.5 s after their release called moving in 45 of 48 (as before); pulls 0.05–0.3 s
    ahead of their log in 0 of 16 (11 before).

    A slope against the run's direction is not motion at the release (a tow from rest never
    starts backwards under its pull): it is the parabola bending to a start that lags the
    release — a thrust that ramps up, the motion growing like τ³ (every thruster tow of
    tests/integration/test_hil_chain.py gave b −0.017 to −0.033 m/s).

    ``serial``: the lag-1 autocorrelation r₁ of the run's residual about the fitted model.
    Seven samples of a correlated noise look like a smooth drift, which the parabola takes as
    a slope while its own residual stays small: b's σ is widened by the AR(1) variance
    inflation √((1 + r₁)/(1 − r₁)) (``stats.misfit.ar1_inflation``; r₁ at most
    ``REST_CHECK_MAX_SERIAL``) (1000 kg tows with ρ 0.9 noise of 3 mm were called
    "moving at the release" in 2 of 6 seeds, their inertia then not identified)."""
    t = np.asarray(run.t, dtype=float)
    x = np.asarray(run.position, dtype=float)
    if rest_before_release(run):
        return None
    after = np.nonzero((t >= run.t_release) & run.window())[0]
    moving = np.nonzero(run.window() & (t > run.t_release))[0]
    if after.size < 3 or moving.size < 2:
        return None
    top = float(np.max(np.abs(np.diff(x[moving]) / np.diff(t[moving])), initial=0.0))
    way = float(np.sign(x[moving[-1]] - x[after[0]]))
    tau_all = t[after] - run.t_release
    mean = np.abs(x[after] - x[after[0]]) / np.where(tau_all > 0, tau_all, np.inf)
    span = after[:REST_CHECK_SAMPLES]
    if t[after[0]] <= run.t_release:  # the record holds its start: read only its parabola
        span = span[mean[:REST_CHECK_SAMPLES] <= REST_CHECK_SPAN_SHARE * top]
    if span.size < REST_CHECK_MIN_SAMPLES:
        return _three_sample_speed(t[after[:3]], x[after[:3]], way, top, _position_step(x))
    tau = t[span] - run.t_release
    design = np.column_stack([np.ones_like(tau), tau, tau**2])
    coef, *_ = np.linalg.lstsq(design, x[span], rcond=None)
    res = x[span] - design @ coef
    dof = max(span.size - 3, 1)
    cov = float(res @ res) / dof * np.linalg.pinv(design.T @ design)
    inflation = ar1_inflation(min(serial, REST_CHECK_MAX_SERIAL))
    sigma = float(np.sqrt(max(cov[1, 1], 0.0) * inflation))
    # the encoder's step is the floor of what a slope over these samples can show
    sigma = max(sigma, _position_step(x) / max(float(np.ptp(tau)), 1e-12))
    b = float(coef[1])
    if b * way > REST_CHECK_SIGMAS * sigma and b * way > REST_CHECK_SHARE * top:
        return b
    return None


def _three_sample_speed(
    t: np.ndarray, x: np.ndarray, way: float, top: float, step: float
) -> float | None:
    """Rule 3 of ``speed_at_release`` on the release sample and the two after it (t [s],
    x, ``way`` the run's direction, ``top`` its largest speed, ``step`` the run's encoder
    step). While the second step is still well within the acceleration (its mean speed v̄₂
    ≤ REST_CHECK_EXTEND_SHARE of the top): the slope at the release of the parabola through
    them, b = v̄₁ − (v̄₂ − v̄₁)·h₁/(h₁ + h₂) (v̄ the steps' mean speeds, h their lengths;
    exactly 0 for a uniformly accelerated start from rest, whatever the steps), beyond
    REST_CHECK_SIGMAS encoder steps over the first step and REST_CHECK_SHARE of the top.
    Else the steps span the acceleration and b is no speed at the release: moving only if
    v̄₁ ≥ REST_CHECK_STEADY·v̄₂."""
    h = np.diff(t)
    first, second = np.diff(x) / h * way
    if second <= REST_CHECK_EXTEND_SHARE * top:
        b = first - (second - first) * h[0] / (h[0] + h[1])
        moving = b > REST_CHECK_SIGMAS * step / h[0] and b > REST_CHECK_SHARE * top
        return float(b * way) if moving else None
    steady = first > REST_CHECK_STEADY * second and first > REST_CHECK_SHARE * top
    return float(first * way) if steady else None


def _position_step(x: np.ndarray) -> float:
    """The encoder's step: the least difference between two distinct positions, or between
    two successive steps (a record that never stands still has no two positions one count
    apart, but its steps change by counts); 0 when neither is seen."""
    changes = np.abs(np.diff(x, 2)) if x.size > 2 else np.empty(0)
    step = min(
        float(np.min(np.diff(np.unique(x)), initial=np.inf)),
        float(np.min(changes[changes > 0], initial=np.inf)),
    )
    return step if np.isfinite(step) else 0.0
