"""The one rule set of the effect search (estimation.stats.acceptance_rules): each rule on
fits built by hand, and each record kind's list of rules and omissions."""

from __future__ import annotations

import inspect

import numpy as np

from estimation.stats import acceptance_rules as rules_module
from estimation.stats.acceptance_rules import (
    DECAY_RULES,
    SEPARABLE,
    TOW_RULES,
    Rival,
    Trial,
)
from estimation.stats.fit_statistics import FitStatistics

N = 2000
SIGMA = 1.1e-4  # position noise, m


def _fit(residuals: np.ndarray, *, sse: float | None = None, p: int = 3, at_bound=()):
    """A fit with ``residuals`` (SSE from them unless given) and ``p`` parameters."""
    return FitStatistics(
        effects=(),
        names=tuple(f"c{i}" for i in range(p)),
        values=np.zeros(p),
        std=np.zeros(p),
        correlation=np.eye(p),
        residuals=(residuals,),
        sse=float(residuals @ residuals) if sse is None else sse,
        n_samples=residuals.size,
        n_params=p,
        at_bound=tuple(at_bound),
    )


def _trial(explained_rms: float, residuals: np.ndarray, **kw) -> Trial:
    """A one-term trial that explains ``explained_rms`` of the current model's residual."""
    fit = _fit(residuals, p=4, at_bound=kw.pop("at_bound", ()))
    current = _fit(residuals, sse=fit.sse + residuals.size * explained_rms**2)
    return Trial(("term",), current, fit, kw.pop("travel", 0.5), **kw)


def _white(seed: int = 1) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, SIGMA, N)


def _ar1(rho: float, seed: int = 2) -> np.ndarray:
    e = np.random.default_rng(seed).normal(0.0, SIGMA, N)
    x = np.empty(N)
    x[0] = e[0]
    for i in range(1, N):
        x[i] = rho * x[i - 1] + e[i]
    return x


def test_a_term_is_measured_against_the_noise_not_the_drive():
    # a damping ~1 % of a restoring torque that moves the motion 15x the noise (KVLCC2)
    assert DECAY_RULES.verdict(_trial(1.7e-3, _white())) == "kept"
    # many samples make a tiny term "significant" (ΔBIC −370): it moves the fit less than
    # the noise
    tiny = _trial(0.5e-4, _white())
    assert tiny.delta_bic < -100
    assert DECAY_RULES.verdict(tiny).startswith("explains 5e-05 RMS, below the noise floor")
    weak = _trial(3e-6, _white())
    assert DECAY_RULES.verdict(weak).startswith("ΔBIC ")


def test_identified_and_physical_bound_come_before_the_evidence():
    assert DECAY_RULES.verdict(_trial(1e-3, _white(), not_identified=("term",))) == (
        "term is not identified by these records"
    )
    assert DECAY_RULES.verdict(_trial(1e-3, _white(), at_bound=("term",))) == (
        "term held at its physical bound"
    )
    assert TOW_RULES.verdict(_trial(1e-3, _white(), at_bound=("term",))) == (
        "term held at its physical bound"
    )


def test_nothing_is_left_to_explain_at_round_off_for_every_kind():
    # noise-free data: the current model is already exact to 1e-9 m on a 0.5 m travel, and
    # a term "explaining" its round-off has a huge ΔBIC
    exact = _trial(1e-9, np.random.default_rng(3).normal(0.0, 1e-12, N))
    assert exact.delta_bic < -1000
    for rule_set in (TOW_RULES, DECAY_RULES):
        assert rule_set.verdict(exact).startswith("the error is already at round-off")


def test_a_rival_is_judged_on_the_effective_sample_size_where_rivals_share_a_direction():
    # the same ΔBIC (−30 on n) against the rival, on a residual with AR(1) ρ 0.9 (n_eff ≈ n/19)
    residual = _ar1(0.9)
    fit = _fit(residual, p=5)
    rival = _fit(residual, sse=fit.sse * np.exp(30.0 / N + np.log(N) / N), p=4)
    assert abs(fit.bic - rival.bic + 30.0) < 1e-6
    trial = Trial(("cubic",), rival, fit, 0.5, rival=Rival("quadratic alone", rival))
    decay_reason = [r.verdict(trial) for r in DECAY_RULES.rules if r.name == "beats its rival"]
    tow_reason = [r.verdict(trial) for r in TOW_RULES.rules if r.name == "beats its rival"]
    assert tow_reason == [None]  # −30 < −10 on n
    assert decay_reason[0] is not None and decay_reason[0].startswith(
        "not better than quadratic alone by ΔBIC 10 on the residual's effective sample size"
    )


def test_a_tow_needs_a_material_cut_a_decay_does_not():
    # the term explains 3x the noise but cuts the RMSE by ~2 %: a slow structure 20x the
    # noise stays, 5x the force-domain floor
    residual = 20 * SIGMA * np.sin(np.linspace(0.0, 6 * np.pi, N)) + _white()
    trial = _trial(3 * SIGMA, residual, floor_ratio=lambda: 5.0)
    assert DECAY_RULES.verdict(trial) == "kept"
    assert TOW_RULES.verdict(trial).startswith("error not cut materially (RMSE −2")
    near_floor = _trial(3 * SIGMA, residual, floor_ratio=lambda: 1.5)
    assert TOW_RULES.verdict(near_floor) == "kept"


def test_costly_evidence_is_asked_for_only_once_the_cheap_rules_pass():
    asked: list[str] = []

    def out_of_sample() -> str | None:
        asked.append("loro")
        return "leave-one-run-out error did not drop"

    weak = _trial(3e-6, _white(), out_of_sample=out_of_sample)
    assert TOW_RULES.verdict(weak).startswith("ΔBIC")
    assert asked == []
    strong = _trial(5e-3, _white(), out_of_sample=out_of_sample)
    assert TOW_RULES.verdict(strong) == "leave-one-run-out error did not drop"
    assert asked == ["loro"]


def test_every_rule_is_applied_or_its_omission_is_explained_for_every_kind():
    names = {
        cls.name
        for _, cls in inspect.getmembers(rules_module, inspect.isclass)
        if cls.__module__ == rules_module.__name__ and isinstance(getattr(cls, "name", None), str)
    }
    assert len(names) >= 8
    for rule_set in (TOW_RULES, DECAY_RULES):
        applied = {r.name for r in rule_set.rules}
        assert applied.isdisjoint(rule_set.omitted)
        assert applied | set(rule_set.omitted) == names
        assert all(why.strip() for why in rule_set.omitted.values())
        doc = rule_set.to_json()
        assert [r["name"] for r in doc["applied"]] == [r.name for r in rule_set.rules]
        assert all(r["statement"] for r in doc["applied"])


def test_the_screen_names_the_share_and_the_parameters():
    assert SEPARABLE.verdict("bias", 0.2, "inertia, K_L or K_Q") is None
    assert SEPARABLE.verdict("bias", 4e-4, "inertia, K_L or K_Q") == (
        "bias is not identified by these records: its effect is a change of inertia, K_L or "
        "K_Q (independent share 0.0004 < 0.001)"
    )
