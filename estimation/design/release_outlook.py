"""The planner's view of a released axis (a pendulum): its one-engine fit, its GUM budget, and
per release amplitude the rig allows what one more record released from it would leave.

For each amplitude A of ``ReleaseEnvelope.amplitudes`` the predicted σ of every coefficient
after one more record from A is ``decay_information.next_releases`` (the fit's Jacobian on
the first record's setting released at rest from A, the records' information and the fit's
own inflation of its white σ), and the run's duration is the fit's model integrated from A
until its swing stays under the run's stop amplitude (``ReleaseEnvelope.stop_amplitude``),
stretched by how much longer the stored records ran than that (``stretch``: the rig's stop
rule lags), plus the procedure's baseline and tail, at most ``max_run_s``. The planner
(``planner._choose_release``) turns these into U and chooses; nothing here decides.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from estimation.design.decay_information import next_releases, planned_record
from estimation.design.information import BASELINE_S, TAIL_S
from estimation.design.planner import (
    BASE,
    AxisState,
    ReleaseOutlook,
    budget_terms,
    correlation_pairs,
)
from estimation.design.planning_envelope import Candidate, ReleaseEnvelope
from estimation.motion.decay_repeats import release_amplitude
from estimation.motion.output_error_fit import MotionFit, simulate
from estimation.motion.records import Record, Setup
from estimation.uncertainty.budget import Budget


def swing_s(
    record: Record, setup: Setup, fit: MotionFit, amplitude: float, env: ReleaseEnvelope
) -> float:
    """Seconds ``fit``'s model swings from ``amplitude`` at rest until it stays within
    ``env.stop_amplitude`` (on ``record``'s setting and sample step; at most
    ``env.max_run_s``)."""
    t = np.asarray(record.t, dtype=float)
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.01
    grid = np.arange(0.0, env.max_run_s, step)
    long = replace(planned_record(record), t=grid, x=np.zeros_like(grid))
    ((x, _),) = simulate([long], setup, fit.names, fit.values, np.array([[amplitude, 0.0]]))
    above = np.flatnonzero(np.abs(x) >= env.stop_amplitude)
    return float(grid[above[-1]] + step) if above.size else step


def stretch(records: Sequence[Record], setup: Setup, fit: MotionFit, env: ReleaseEnvelope) -> float:
    """How much longer the records ran than the model swings from their releases (median
    of length / ``swing_s``, at least 1): the rig stops on the amplitude over the last full
    cycle, which lags the swing's first staying under the stop amplitude (simulated
    pendulum: a record of 55 s from 0.276 rad whose model swing stays under 5 mrad after
    40 s)."""
    ratios = [
        (float(r.t[-1] - r.t[0])) / swing_s(r, setup, fit, release_amplitude(r), env)
        for r in records
    ]
    return max(float(np.median(ratios)), 1.0)


def decay_duration(
    record: Record,
    setup: Setup,
    fit: MotionFit,
    amplitude: float,
    env: ReleaseEnvelope,
    scale: float = 1.0,
) -> float:
    """Seconds a run released from ``amplitude`` lasts: its baseline, ``swing_s`` × ``scale``
    (``stretch``; at most ``env.max_run_s``) and its tail."""
    swing = min(scale * swing_s(record, setup, fit, amplitude, env), env.max_run_s)
    return BASELINE_S + swing + TAIL_S  # fmt: skip


def release_outlooks(
    records: Sequence[Record], setup: Setup, fit: MotionFit, env: ReleaseEnvelope
) -> tuple[ReleaseOutlook, ...]:
    """Per release amplitude ``env`` offers: the σ predicted after it and its duration;
    () when the fit's σ are not all known (``next_releases``)."""
    planned = next_releases(records, setup, fit, env.amplitudes(), env.unit)
    scale = stretch(records, setup, fit, env) if planned else 1.0
    return tuple(
        ReleaseOutlook(
            p.amplitude,
            {n: float(s) for n, s in zip(p.names, p.std_after, strict=True)},
            decay_duration(records[0], setup, fit, p.amplitude, env, scale),
        )
        for p in planned
    )


def state_from_release(
    result: object,
    recorded: Sequence[Candidate],
    budget: Budget | None,
    env: ReleaseEnvelope,
) -> AxisState:
    """The planner's view of a released axis's ``EstimationResult`` (its output-error fit,
    records and setup) and its ``budget`` (None: U = 2σ): the target coefficients are those
    of M, K_L, K_Q the fit carries."""
    r = result  # duck-typed: an estimation.motion.estimation_result.EstimationResult
    fit: MotionFit | None = r.fit_after  # type: ignore[attr-defined]
    setup: Setup | None = r.setup  # type: ignore[attr-defined]
    records: tuple[Record, ...] = r.records  # type: ignore[attr-defined]
    if fit is None or setup is None or not records:
        raise ValueError("result: got a fit without its model, allowed: an output-error fit")
    values = {n: float(v) for n, v in zip(fit.names, fit.values, strict=True)}
    std = {n: float(s) for n, s in zip(fit.names, fit.std, strict=True)}
    pairs = correlation_pairs(fit.names, fit.correlation)
    return AxisState(
        axis=env.axis,
        values=values,
        std=std,
        correlation=pairs,
        ambiguous=tuple(tuple(g) for g in r.ambiguous),  # type: ignore[attr-defined]
        rmse=float(fit.rmse),
        recorded=tuple(recorded),
        **budget_terms(budget, std, r.names),  # type: ignore[attr-defined]
        targets=tuple(n for n in BASE if n in values),
        releases=release_outlooks(records, setup, fit, env),
        names=dict(r.names),  # type: ignore[attr-defined]
    )
