"""Synthetic records for the term-library tests, from scipy's solve_ivp on the equation
written out here (never the project's simulator): tow sets at 10, 143 and 1000 kg with any
library effect, and heave decays with any decay term; each noise-free path is integrated
once per case (``cache``), the seeds differ only in dither and noise.

The integrator is DOP853 (8th order) at rtol 1e-10: it takes a third of RK45's steps at
that tolerance (the 45 decay and 64 tow paths of the library tests: 8.4 -> 3.8 s of CPU).
Both stay within 4e-11 m of a rtol-1e-13 reference on the decays (RK45 ≤ 1.1e-11 m, DOP853
≤ 3.7e-11 m), six decades under their ≥ 2e-5 m of noise. Every quantized tow the tests draw
(the clean sets at seeds 0–560, the single effects at 31, the pairs at 32) is RK45's to the
last bit; over all 70 cases × 561 seeds, 4 runs of 157,080 (seeds never drawn) differ."""

from __future__ import annotations

from functools import cache

import numpy as np
from scipy.integrate import solve_ivp

from estimation import RunData
from estimation.motion.terms import STANDARD_GRAVITY

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
        rhs,
        (0.0, tau[-1] + 0.1),
        [0.0, 0.0],
        method="DOP853",
        dense_output=True,
        rtol=1e-10,
        atol=1e-12,
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
def _decay_path(scale, b2, b3, k3, fc, drift=0.0, damping=1.0, release=0.05):
    """Noise-free samples (t, x) of one free decay (the physics of ``decay``), integrated
    once per case: every seed shares them, only the noise differs. Read-only arrays."""
    m = SCALES[scale][0]
    total, k = 1.8 * m, 40.0 * m
    b1 = damping * 0.03 * 2 * np.sqrt(total * k)
    t = np.arange(0.0, 15.0, 1.0 / 20.0)
    x = np.empty_like(t)
    start, state = 0.0, [release, 0.0]
    while start < t[-1]:  # one half-swing at a time: dry friction's sign is fixed in each
        pull = drift * start - (k * state[0] + k3 * state[0] ** 3)
        if abs(pull) <= fc:  # held by dry friction: at rest from here on
            x[t >= start] = state[0]
            break
        s = np.sign(pull)

        def rhs(t_, y, s=s):
            f = b1 * y[1] + b2 * abs(y[1]) * y[1] + b3 * y[1] ** 3 + fc * s - drift * t_
            return [y[1], -(f + k * y[0] + k3 * y[0] ** 3) / total]

        def turn(_t, y, s=s):
            return y[1]

        turn.terminal, turn.direction = True, -s
        sol = solve_ivp(
            rhs,
            (start, t[-1]),
            state,
            events=turn,
            method="DOP853",
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


def decay(
    scale, seed, *, b2=0.0, b3=0.0, k3=0.0, fc=0.0, drift=0.0, noise=2e-5, damping=1.0, release=0.05
):
    """A heave-like free decay of (M + 0.8 M) from ``release`` (0.05 m), hydrostatic
    k = 40·M: 1.8 M ẍ + b₁ẋ + b₂|ẋ|ẋ + b₃ẋ³ + F_c sign ẋ + k x + k₃x³ = d·t, with white
    noise; b₁ = ``damping`` × 3 % of critical."""
    m = SCALES[scale][0]
    total, k = 1.8 * m, 40.0 * m
    b1 = damping * 0.03 * 2 * np.sqrt(total * k)
    t, x = _decay_path(scale, b2, b3, k3, fc, drift, damping, release)
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
        # the equilibrium moves 5 mm (10 % of the release offset) over the 15 s record
        "equilibrium_drift": ("drift", 40.0 * m * 0.005 / 15.0),
    }[name]


TOW_EFFECTS = (
    "coulomb_friction",
    "constant_bias",
    "restoring_spring",
    "cubic_drag",
    "release_delay",
    "drive_inertia",
)
DECAY_EFFECTS = (
    "quadratic_damping",
    "cubic_drag",
    "cubic_stiffness",
    "coulomb_friction",
    "equilibrium_drift",
)
#: Base terms every fit carries (their recovery is checked with each case).
BASE = ("linear_damping", "quadratic_damping", "restoring_spring")


#: Restoring terms recovered as the base of a swing (``test_sine_restoring_is_recovered``).
SWING_TERMS = ("sine_restoring",)
