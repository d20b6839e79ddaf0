"""Where a free decay ends (``estimation.motion.decay_end``), on decays from scipy's solve_ivp
(not the project's integrator): a clean decay is kept to its end, an outside event that
takes or brings energy ends it, and the fit then reads only the free part."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from estimation.motion.decay_end import free_decay_end
from estimation.motion.decay_estimate import estimate_decay
from tests.estimation.term_cases import SCALES, decay, decay_effect

TOTAL, B1, B2, K = 1.8, 0.12, 0.4, 40.0  # kg, N·s/m, N·s²/m², N/m: period 1.33 s, ζ ≈ 0.007
EVENT = 12.0  # s: when the outside event starts


@cache
def _path(event: str) -> tuple[np.ndarray, np.ndarray]:
    """The noise-free decay of ``record`` (read-only: every seed shares it)."""

    def rhs(t, s):
        x, v = s
        extra = 0.0
        if t >= EVENT and event == "catch":
            extra = 30 * B1 * v
        if t >= EVENT and event == "push":
            extra = -3 * B1 * v
        return [v, -(B1 * v + B2 * abs(v) * v + K * x + extra) / TOTAL]

    t = np.arange(0.0, 30.0, 0.05)
    sol = solve_ivp(rhs, (0, t[-1]), [0.05, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.01)
    x = sol.y[0]
    t.flags.writeable = x.flags.writeable = False
    return t, x


def record(event: str = "none", noise: float = 2e-5, seed: int = 0):
    """t, x of a decay from 0.05 m, 30 s at 20 Hz, with white noise. ``event``: "catch"
    (from ``EVENT`` a hand adds 30× the linear damping), "push" (from ``EVENT`` something
    outside pushes along the motion with 3× the linear damping: a wave arriving in phase)
    or "none"."""
    t, x = _path(event)
    rng = np.random.default_rng(seed)
    return t.copy(), x + noise * rng.standard_normal(t.size)


@pytest.mark.parametrize("seed", range(10))
def test_a_clean_decay_is_kept_to_its_end(seed):
    t, x = record(seed=seed)
    window = free_decay_end(t, x, 2e-5)
    assert window.end == t[-1] and window.ended_by == "end of the record"


@pytest.mark.parametrize("event", ["catch", "push"])
def test_an_outside_event_ends_the_free_decay(event):
    t, x = record(event)
    window = free_decay_end(t, x, 2e-5)
    period = 2 * np.pi * np.sqrt(TOTAL / K)
    assert EVENT - period <= window.end <= EVENT + 2 * period, window
    assert ("taken out" if event == "catch" else "came in") in window.ended_by


def test_the_fit_reads_the_free_part_and_reports_its_window():
    t, x = record("catch")
    r = estimate_decay(t, x, "heave", known_inertia=1.0, stiffness=K, candidates=())
    doc = r.to_json()
    end = doc["window"]["decay"]["end_time_s"]
    assert end <= EVENT + 2 * np.sqrt(TOTAL / K) * np.pi * 2
    assert "taken out" in doc["window"]["decay"]["ended_by"]
    # B₂ is not offered: the linear damping takes the quadratic's share, within what the
    # free part holds, and never the catch's 30×
    assert r.coefficients["linear_damping"].value < 3 * B1
    assert r.coefficients["inertia"].value == pytest.approx(0.8, rel=0.02)


def test_a_given_end_is_kept():
    t, x = record("catch")
    r = estimate_decay(t, x, "heave", known_inertia=1.0, stiffness=K, t_end=25.0)
    assert r.section.window["decay"].end == 25.0 and r.section.window["decay"].ended_by == "given"


def test_the_report_shows_the_window_and_plots_only_the_free_part(tmp_path):
    from estimation.motion.decay_report import fitted_window, write_decay_report
    from estimation.motion.records import Record

    t, x = record("catch")
    r = estimate_decay(t, x, "heave", known_inertia=1.0, stiffness=K, candidates=())
    write_decay_report(r, [Record("decay", t, x)], tmp_path)
    text = (tmp_path / "report.md").read_text()
    assert f"to {r.section.window['decay'].end:.4g} s (the half-cycle from" in text
    shown, _, _ = fitted_window(r, Record("decay", t, x))
    assert shown[-1] + r.section.release_time_s["decay"] <= r.section.window["decay"].end


@pytest.mark.parametrize("scale", list(SCALES))
def test_a_decay_held_by_dry_friction_ends_where_it_comes_to_rest(scale):
    """Quadratic damping and dry friction (``term_cases``: the body sticks at 9.35 s and
    rests for 5.6 s): the window ends at the rest, and both terms come out within 2 % —
    fitted to the whole record they converged 20 % low together (the misfit jumps with the
    swing on which the model sticks)."""
    kw = dict(decay_effect(n, scale) for n in ("quadratic_damping", "coulomb_friction"))
    t, x, truth = decay(scale, seed=40, **kw)
    r = estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    window = r.section.window["decay"]
    assert 9.0 < window.end < 9.6 and window.ended_by.startswith("the body came to rest")
    assert set(r.effect_names) == {"quadratic_damping", "coulomb_friction"}, r.steps
    assert r.coefficients["quadratic_damping"].value == pytest.approx(kw["b2"], rel=0.02)
    assert r.coefficients["coulomb_friction"].value == pytest.approx(kw["fc"], rel=0.02)


def test_a_decay_whose_swings_stay_above_the_noise_does_not_rest():
    """The same body without friction still swings 3 mm (150σ) at 15 s: no rest."""
    field, b2 = decay_effect("quadratic_damping", "143kg")
    t, x, _ = decay("143kg", seed=40, **{field: b2})
    assert free_decay_end(t, x, 2e-5).ended_by == "end of the record"


def _dropout(t, x, start=6.0, length=1.2):
    """The record with ``length`` s of samples from ``start`` lost (a logging dropout)."""
    keep = ~((t > start) & (t < start + length))
    return t[keep], x[keep]


def test_a_dropout_is_not_read_as_energy_taken_out():
    """A 1.2 s dropout (about a period) in a clean decay: the half-cycle read across it
    spans turns never seen, and was called "energy was taken out" (the window ended at
    5.7 s of 30). The envelope is read piece by piece, so the whole record is fitted and
    the quadratic damping comes out within 5 %."""
    t, x = _dropout(*record())
    assert free_decay_end(t, x, 2e-5).ended_by == "end of the record"
    r = estimate_decay(t, x, "heave", known_inertia=1.0, stiffness=K)
    assert r.section.window["decay"].end == t[-1]
    assert r.coefficients["quadratic_damping"].value == pytest.approx(B2, rel=0.05)


def test_a_catch_after_a_dropout_still_ends_the_decay():
    """Reading the envelope piece by piece still sees energy taken out after a gap."""
    t, x = _dropout(*record("catch"))
    window = free_decay_end(t, x, 2e-5)
    assert "taken out" in window.ended_by and window.end > 7.2
