"""Every entry of the term library is recovered from data it generated, at 10, 143 and
1000 kg: tows through ``estimate`` and decays through ``estimate_decay``. The data come from
scipy's solve_ivp on the equation written out here, never from the project's simulator.

An entry added to ``estimation.motion.terms.LIBRARY`` without a case here fails
``test_every_library_entry_has_a_case``: an effect added half-way cannot weaken the search
in silence.
"""

from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation import RunData, estimate
from estimation.motion.decay import estimate_decay
from estimation.motion.fit import fit_motion
from estimation.motion.records import Record, Setup
from estimation.motion.terms import LIBRARY, STANDARD_GRAVITY

#: (inertia kg, K_L N·s/m, K_Q N·s²/m², forward drives N) per scale.
SCALES = {
    "10kg": (10.0, 2.0, 15.0, (0.6, 1.5, 3.0, 6.0)),
    "143kg": (143.26, 20.16, 241.14, (4.9, 24.5, 44.1, 83.3)),
    "1000kg": (1000.0, 150.0, 1500.0, (60.0, 150.0, 300.0, 600.0)),
}
QUANTUM = 1e-4  # m, encoder step
RATE = 10.0  # Hz


@cache
def _tow_path(scale, force, coulomb, bias, spring, cubic, delay, hung, duration):
    """Noise-free positions of one tow at the samples (m): the physics of ``tow_run``,
    integrated once per case (every seed shares it; only the dither differs). Read-only."""
    m, k_l, k_q, _ = SCALES[scale]
    total = m + (abs(force) / STANDARD_GRAVITY if hung else 0.0)
    s = np.sign(force + bias)

    def rhs(_t, y):
        x, v = y
        net = force + bias - coulomb * s - k_l * v - k_q * abs(v) * v - cubic * v**3 - spring * x
        return [v, net / total]

    t = np.arange(0.0, duration, 1.0 / RATE)
    tau = np.clip(t - 1.0 - delay, 0.0, None)
    sol = solve_ivp(
        rhs, (0.0, tau[-1] + 0.1), [0.0, 0.0], dense_output=True, rtol=1e-10, atol=1e-12
    )
    x = sol.sol(tau)[0]
    t.flags.writeable = x.flags.writeable = False
    return t, x


def tow_run(
    i,
    scale,
    force,
    seed,
    *,
    coulomb=0.0,
    bias=0.0,
    spring=0.0,
    cubic=0.0,
    delay=0.0,
    hung=False,
    duration=20.0,
):
    """One tow from rest at t = 1 s (1 s baseline):
    (M [+ |F|/g]) ẍ = F + b − F_c·sign(F + b) − K_L ẋ − K_Q |ẋ|ẋ − K_C ẋ³ − k x,
    dithered by the seed and quantized to the encoder step."""
    t, x = _tow_path(scale, force, coulomb, bias, spring, cubic, delay, hung, duration)
    rng = np.random.default_rng(seed + i)
    x = np.round((x + rng.uniform(0, QUANTUM)) / QUANTUM) * QUANTUM
    return RunData(f"run-{i}", "surge", t.copy(), x, drive=force, t_release=1.0, hung_mass_kg=None)


def tow_set(scale, seed, reverse=False, **effects):
    drives = SCALES[scale][3]
    if reverse:
        drives = tuple(d if i % 2 == 0 else -d for i, d in enumerate(drives))
    return [tow_run(i, scale, d, seed, **effects) for i, d in enumerate(drives)]


def tow_effect(name, scale):
    """(physics keyword, true value, reverse runs needed) of one axis effect at a scale."""
    _, _, k_q, drives = SCALES[scale]
    return {
        "coulomb_friction": ("coulomb", 0.05 * drives[1], True),
        "constant_bias": ("bias", 0.03 * drives[1], True),
        "restoring_spring": ("spring", 0.05 * drives[0], False),
        "cubic_drag": ("cubic", 0.5 * k_q, False),
        "release_delay": ("delay", 0.15, False),
        "drive_inertia": ("hung", 1.0, False),
    }[name]


@cache
def _decay_path(scale, b2, b3, k3, fc):
    """Noise-free samples (t, x) of one free decay (the physics of ``decay``), integrated
    once per case: every seed shares them, only the noise differs. Read-only arrays."""
    m = SCALES[scale][0]
    total, k = 1.8 * m, 40.0 * m
    b1 = 0.03 * 2 * np.sqrt(total * k)
    t = np.arange(0.0, 15.0, 1.0 / 20.0)
    x = np.empty_like(t)
    start, state = 0.0, [0.05, 0.0]
    while start < t[-1]:  # one half-swing at a time: dry friction's sign is fixed in each
        pull = -(k * state[0] + k3 * state[0] ** 3)
        if abs(pull) <= fc:  # held by dry friction: at rest from here on
            x[t >= start] = state[0]
            break
        s = np.sign(pull)

        def rhs(_t, y, s=s):
            f = b1 * y[1] + b2 * abs(y[1]) * y[1] + b3 * y[1] ** 3 + fc * s
            return [y[1], -(f + k * y[0] + k3 * y[0] ** 3) / total]

        def turn(_t, y, s=s):
            return y[1]

        turn.terminal, turn.direction = True, -s
        sol = solve_ivp(
            rhs,
            (start, t[-1]),
            state,
            events=turn,
            dense_output=True,
            rtol=1e-10,
            atol=1e-13,
            first_step=1e-4,
        )
        inside = (t >= start) & (t <= sol.t[-1])
        x[inside] = sol.sol(t[inside])[0]
        start, state = float(sol.t[-1]), [float(sol.y[0, -1]), 0.0]
        if not sol.t_events[0].size:
            break
    t.flags.writeable = x.flags.writeable = False
    return t, x


def decay(scale, seed, *, b2=0.0, b3=0.0, k3=0.0, fc=0.0, noise=2e-5):
    """A heave-like free decay of (M + 0.8 M) from 0.05 m, hydrostatic k = 40·M:
    1.8 M ẍ + b₁ẋ + b₂|ẋ|ẋ + b₃ẋ³ + F_c sign ẋ + k x + k₃x³ = 0, with white noise."""
    m = SCALES[scale][0]
    total, k = 1.8 * m, 40.0 * m
    b1 = 0.03 * 2 * np.sqrt(total * k)
    t, x = _decay_path(scale, b2, b3, k3, fc)
    rng = np.random.default_rng(seed)
    x = x + noise * rng.standard_normal(t.size)
    return t.copy(), x, dict(added=0.8 * m, k=k, b1=b1, known=m)


def decay_effect(name, scale):
    """Keyword and value of a decay term at a scale (amplitude 0.05 m, speed ≈ 0.24 m/s)."""
    m = SCALES[scale][0]
    return {
        "quadratic_damping": ("b2", 4.0 * m),
        "cubic_drag": ("b3", 40.0 * m),
        "cubic_stiffness": ("k3", 0.3 * 40.0 * m / 0.05**2),
        "coulomb_friction": ("fc", 0.01 * 40.0 * m * 0.05),
    }[name]


TOW_EFFECTS = (
    "coulomb_friction",
    "constant_bias",
    "restoring_spring",
    "cubic_drag",
    "release_delay",
    "drive_inertia",
)
DECAY_EFFECTS = ("quadratic_damping", "cubic_drag", "cubic_stiffness", "coulomb_friction")
#: Base terms every fit carries (their recovery is checked with each case).
BASE = ("linear_damping", "quadratic_damping", "restoring_spring")


#: Restoring terms recovered as the base of a swing (``test_sine_restoring_is_recovered``).
SWING_TERMS = ("sine_restoring",)


def test_every_library_entry_has_a_case():
    covered = set(TOW_EFFECTS) | set(DECAY_EFFECTS) | set(BASE) | set(SWING_TERMS)
    assert set(LIBRARY) <= covered, f"no recovery case for {set(LIBRARY) - covered}"


def _slow_unless(scale):
    return () if scale == "143kg" else (pytest.mark.slow,)


@pytest.mark.parametrize(
    ("scale", "effect"),
    [pytest.param(s, e, marks=_slow_unless(s)) for s in SCALES for e in TOW_EFFECTS],
)
def test_tow_effect_alone_is_recovered(scale, effect):
    field, value, reverse = tow_effect(effect, scale)
    runs = tow_set(scale, seed=31, reverse=reverse, **{field: value})
    doc = estimate(runs, n_bootstrap=0).to_json()
    found = {e["name"]: e["value"] for e in doc["effects"]}
    assert effect in found, doc["evidence"]["steps"]
    assert found[effect] == pytest.approx(value, rel=0.10)
    m, _, k_q, _ = SCALES[scale]
    c = doc["coefficients"]
    assert c["inertia"]["value"] == pytest.approx(m, rel=0.10)
    assert c["quadratic_damping"]["value"] == pytest.approx(k_q, rel=0.10)


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
@pytest.mark.parametrize(
    "pair",
    [
        ("coulomb_friction", "constant_bias"),
        ("restoring_spring", "cubic_drag"),
        ("coulomb_friction", "restoring_spring"),
    ],
)
def test_tow_effects_in_pairs_are_recovered(scale, pair):
    effects, reverse = {}, False
    for name in pair:
        field, value, rev = tow_effect(name, scale)
        effects[field] = value
        reverse |= rev
    runs = tow_set(scale, seed=32, reverse=reverse, **effects)
    doc = estimate(runs, n_bootstrap=0).to_json()
    found = {e["name"]: e["value"] for e in doc["effects"]}
    for name in pair:
        field, value, _ = tow_effect(name, scale)
        assert found.get(name) == pytest.approx(value, rel=0.10), (name, found)


@pytest.mark.parametrize(
    ("scale", "effect"),
    [pytest.param(s, e, marks=_slow_unless(s)) for s in SCALES for e in DECAY_EFFECTS],
)
def test_decay_term_alone_is_recovered(scale, effect):
    field, value = decay_effect(effect, scale)
    t, x, truth = decay(scale, seed=33, **{field: value})
    r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    assert effect in r.effects, [(s.term, s.reason) for s in r.steps]
    assert r.coefficients[effect].value == pytest.approx(value, rel=0.10)
    assert r.coefficients["inertia"].value == pytest.approx(truth["added"], rel=0.02 * 1.8 / 0.8)
    assert r.coefficients["linear_damping"].value == pytest.approx(truth["b1"], rel=0.10)


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_decay_terms_in_a_pair_are_recovered(scale):
    (f1, v1), (f2, v2) = (
        decay_effect("quadratic_damping", scale),
        decay_effect("cubic_stiffness", scale),
    )
    t, x, truth = decay(scale, seed=34, **{f1: v1, f2: v2})
    r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    assert r.coefficients["quadratic_damping"].value == pytest.approx(v1, rel=0.10)
    assert r.coefficients["cubic_stiffness"].value == pytest.approx(v2, rel=0.10)


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_clean_decays_claim_no_term_in_98_percent_of_seeds(scale):
    claims = 0
    for seed in range(50):
        t, x, truth = decay(scale, seed)
        r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
        claims += bool(r.effects)
    assert claims <= 1


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_clean_tows_claim_no_effect_in_98_percent_of_seeds(scale):
    claims = 0
    for seed in range(50):
        runs = tow_set(scale, seed=100 + seed)
        claims += bool(estimate(runs, n_bootstrap=0).effects)
    assert claims <= 1


#: Known gap (issue 20, open): at 143 kg the inertia's σ is too small on these records: over
#: the 50 seeds z = (θ̂ − θ)/σ has mean 0.09 and RMS 1.31 (41 of 50 inside 2σ), with the
#: within-record serial-correlation σ (``estimation.stats.serial``) as with the white one.
#: The position error is the encoder's quantization of one smooth motion, a deterministic
#: function of the run's dither phase: the inertia's error from a run is 0.7–1.6× (1.32×
#: over the four) what white noise of Q/√12 gives, through correlation between the start
#: and the steady part of the same run (seconds apart), while the residual left by the fit
#: looks white (lag-1 ρ ≈ −0.1): no estimate from the residual sees it (docs/estimation.md).
#: Strict: it fails the day the σ accounts for it, to be turned into a pass.
SIGMA_TOO_SMALL = pytest.mark.xfail(
    strict=True,
    reason="quantization of one smooth motion: error correlated across a run, residual white",
)

#: An honest σ gives z ~ N(0, 1): median |z| = 0.674, and the median of 50 |z| has sd
#: √(0.25/50)/(2·φ(0.674)) ≈ 0.11. Below 0.674 − 3·0.11 ≈ 0.34 (p < 0.2 % for an honest σ)
#: the σ is more than about 2× too large: intervals absurdly wide.
MEDIAN_ABS_Z_MIN = 0.34


def _coverage(fits, truth):
    """Hits inside 2σ and median |z| per parameter over seeds (σ None/NaN: a miss)."""
    z = {name: [] for name in truth}
    for coefficients in fits:
        for name, true in truth.items():
            c = coefficients[name]
            ok = c.std is not None and np.isfinite(c.std) and c.std > 0
            z[name].append(abs(c.value - true) / c.std if ok else np.inf)
    hits = {n: int(np.sum(np.array(v) <= 2)) for n, v in z.items()}
    return hits, {n: float(np.median(v)) for n, v in z.items()}


@pytest.mark.slow
@pytest.mark.parametrize(
    "scale",
    [pytest.param(s, marks=SIGMA_TOO_SMALL) if s == "143kg" else s for s in SCALES],
)
def test_tow_two_sigma_intervals_cover_the_truth(scale):
    """Rule: with honest σ, |θ̂ − θ| ≤ 2σ holds with p ≈ 0.95 per seed; ≥ 45 of 50 (90 %)
    fails for a true p = 0.95 with probability ≈ 4 % (binomial), for p ≤ 0.85 in ≥ 88 %.
    And not absurdly wide: median |z| ≥ ``MEDIAN_ABS_Z_MIN``."""
    m, k_l, k_q, _ = SCALES[scale]
    truth = {"inertia": m, "linear_damping": k_l, "quadratic_damping": k_q}
    fits = (
        estimate(tow_set(scale, seed=300 + seed), search_effects=False, n_bootstrap=0)
        for seed in range(50)
    )
    hits, median = _coverage((r.coefficients for r in fits), truth)
    assert min(median.values()) >= MEDIAN_ABS_Z_MIN, median
    assert min(hits.values()) >= 45, hits


def correlated_noise(size, seed, sd=3e-4, rho=0.8):
    """AR(1) position noise of standard deviation ``sd`` (m) and lag-1 correlation ``rho``:
    a sensor behind a first-order low-pass of time constant 0.45 s sampled at 10 Hz
    (ρ = exp(−0.1/0.45) ≈ 0.8), three encoder steps in size."""
    rng = np.random.default_rng(seed)
    noise = np.empty(size)
    noise[0] = sd * rng.standard_normal()
    for k in range(1, size):
        noise[k] = rho * noise[k - 1] + sd * np.sqrt(1 - rho**2) * rng.standard_normal()
    return noise


@pytest.mark.slow
def test_tow_two_sigma_intervals_cover_the_truth_with_correlated_noise():
    """The same rules when the position noise is correlated in time (a white-residual σ
    covers about 22 of 50 here: ``estimation.stats.serial`` is what passes this)."""
    m, k_l, k_q, _ = SCALES["143kg"]
    truth = {"inertia": m, "linear_damping": k_l, "quadratic_damping": k_q}
    fits = []
    for seed in range(50):
        runs = [
            replace(r, position=r.position + correlated_noise(r.t.size, 10_000 + 10 * seed + i))
            for i, r in enumerate(tow_set("143kg", seed=400 + seed))
        ]
        fits.append(estimate(runs, search_effects=False, n_bootstrap=0).coefficients)
    hits, median = _coverage(fits, truth)
    assert min(median.values()) >= MEDIAN_ABS_Z_MIN, median
    assert min(hits.values()) >= 45, hits


@pytest.mark.slow
@pytest.mark.parametrize("scale", list(SCALES))
def test_decay_two_sigma_intervals_cover_the_truth(scale):
    fits, truths = [], []
    for seed in range(50):
        t, x, truth = decay(scale, 200 + seed, noise=2e-4)
        r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
        fits.append(r.coefficients)
        truths.append({"inertia": truth["added"], "linear_damping": truth["b1"]})
    assert all(tr == truths[0] for tr in truths)  # one truth per scale
    hits, median = _coverage(fits, truths[0])
    assert min(median.values()) >= MEDIAN_ABS_Z_MIN, median
    assert min(hits.values()) >= 45, hits


def test_a_tow_recorded_after_its_release_never_reports_a_confident_inertia():
    """The record starts 3 s after the release, near the steady speed, with the release
    taken as its first sample."""
    runs = []
    for run in tow_set("143kg", seed=35):
        keep = run.t >= 4.0
        runs.append(
            RunData(
                run.run_id,
                "surge",
                run.t[keep],
                run.position[keep],
                drive=run.drive,
                t_release=float(run.t[keep][0]),
            )
        )
    r = estimate(runs, n_bootstrap=0)
    inertia = r.coefficients["inertia"]
    confident = np.isfinite(inertia.std) and inertia.value > 2 * inertia.std
    assert not confident or abs(inertia.value - SCALES["143kg"][0]) <= 2 * inertia.std
    assert any("inertia is not identified" in w for w in r.warnings)


@pytest.mark.parametrize("scale", [pytest.param(s, marks=_slow_unless(s)) for s in SCALES])
def test_sine_restoring_is_recovered(scale):
    """A pendulum-like roll swing from 0.5 rad, 1.8 M·φ̈ + b₁·φ̇ + k·sin φ = 0 (M kg·m²), the
    inertia known: k within 1 %; a linear spring in its place misfits (the period of a swing
    from φ₀ is ≈ φ₀²/16 = 1.6 % longer than the linear one)."""
    m = SCALES[scale][0]
    total, k = 1.8 * m, 4.0 * m
    b1 = 0.02 * 2 * np.sqrt(total * k)
    t = np.arange(0.0, 40.0, 0.1)
    sol = solve_ivp(
        lambda _t, y: [y[1], -(b1 * y[1] + k * np.sin(y[0])) / total],
        (0.0, t[-1]),
        [0.5, 0.0],
        t_eval=t,
        rtol=1e-11,
        atol=1e-13,
    )
    x = sol.y[0] + 2e-5 * np.random.default_rng(5).standard_normal(t.size)
    record = Record("swing", t, x)
    fits = {
        term: fit_motion([record], Setup("roll", m, 0.8 * m, {}, ("linear_damping", term)))
        for term in ("sine_restoring", "restoring_spring")
    }
    sine = fits["sine_restoring"]
    assert sine.value("sine_restoring") == pytest.approx(k, rel=0.01)
    assert sine.value("linear_damping") == pytest.approx(b1, rel=0.05)
    assert sine.rmse < 1e-4 < fits["restoring_spring"].rmse
