"""A release found in the data, refined by the axis model itself (the window of a
recording is found in :mod:`estimation.data.window`; this needs the model, so it lives
beside it)."""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
from scipy.optimize import minimize_scalar

from estimation.axis.model import prepare
from estimation.axis.output_error import fit_output_error
from estimation.data.runs import RunData

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
        high = found.t_release + ONSET_SEARCH_S
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


#: Samples after the release the start-at-rest check fits a parabola to.
REST_CHECK_SAMPLES = 7
#: |v(release)| beyond this many σ of the local fit, and …
REST_CHECK_SIGMAS = 3.0
#: … beyond this share of the run's largest speed, is motion at the release.
REST_CHECK_SHARE = 0.05


def speed_at_release(run: RunData, serial: float = 0.0) -> float | None:
    """The speed at the release (m/s or rad/s) when the data show the body already moving
    there, else None. A tow or spin starts from rest: x − x₀ = c·τ² near the release. A
    parabola x = a + b·τ + c·τ² over the first ``REST_CHECK_SAMPLES`` samples after it
    gives b with its σ; b beyond REST_CHECK_SIGMAS σ and REST_CHECK_SHARE of the run's
    largest speed, and the way the run goes, means the record starts after the release
    (already moving). A slope against the run's direction is not motion at the release (a
    tow from rest never starts backwards under its pull): it is the parabola bending to a
    start that lags the release — a thrust that ramps up, the motion growing like τ³ (every
    thruster tow of tests/integration/test_hil_chain.py gave b −0.017 to −0.033 m/s).

    ``serial``: the lag-1 autocorrelation r₁ of the run's residual about the fitted model.
    Seven samples of a correlated noise look like a smooth drift, which the parabola takes as
    a slope while its own residual stays small: b's σ is widened by the AR(1) variance
    inflation √((1 + r₁)/(1 − r₁)) (1000 kg tows with ρ 0.9 noise of 3 mm were called
    "moving at the release" in 2 of 6 seeds, their inertia then not identified)."""
    t = np.asarray(run.t, dtype=float)
    x = np.asarray(run.position, dtype=float)
    after = np.nonzero((t >= run.t_release) & run.window())[0][:REST_CHECK_SAMPLES]
    if after.size < 4:
        return None
    tau = t[after] - run.t_release
    design = np.column_stack([np.ones_like(tau), tau, tau**2])
    coef, *_ = np.linalg.lstsq(design, x[after], rcond=None)
    res = x[after] - design @ coef
    dof = max(after.size - 3, 1)
    cov = float(res @ res) / dof * np.linalg.pinv(design.T @ design)
    r1 = min(max(serial, 0.0), 0.99)
    sigma = float(np.sqrt(max(cov[1, 1], 0.0) * (1 + r1) / (1 - r1)))
    # the encoder's step is the floor of what a slope over these samples can show
    step = float(np.min(np.abs(np.diff(np.unique(x))), initial=np.inf)) if x.size > 1 else 0.0
    sigma = max(sigma, (step if np.isfinite(step) else 0.0) / max(float(np.ptp(tau)), 1e-12))
    moving = np.nonzero(run.window() & (t > run.t_release))[0]
    top = float(np.max(np.abs(np.diff(x[moving]) / np.diff(t[moving])), initial=0.0))
    b = float(coef[1])
    way = np.sign(x[moving[-1]] - x[after[0]]) if moving.size else 0.0
    if b * way > REST_CHECK_SIGMAS * sigma and b * way > REST_CHECK_SHARE * top:
        return b
    return None
