"""Pre-test analysis (ITTC 7.5-02-01-01 §3): the expanded uncertainty a planned campaign
will reach on each coefficient, before the tank is booked.

Each planned run is simulated with the current model of its axis by scipy's solve_ivp
(an integrator independent of the estimator's closed form and RK4):

    (M + M_drive)·v̇ + K_L·v + K_Q·|v|·v = τ,   M_drive = m_w + J_p/r_p² (surge),
                                                 m_w·r_d² + J_d (yaw)

from rest at the release until it has travelled ``travel`` or ``max_time_s`` has passed,
sampled at ``rate_hz`` by an encoder of step ``position_step`` (plus noise of a third of a
step, dithering the quantization). The simulated campaign is then estimated and given its
budget exactly as a recorded one (same declared tolerances, same release σ, repeats as
planned), so the prediction includes every source the real budget will hold. Run-to-run
scatter a real rig adds beyond the declared sources is not predicted: that is what the
repeats measure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from estimation.axis.tow_estimate import estimate
from estimation.data.run_arrays import RunData
from estimation.errors import FieldError
from estimation.uncertainty.budget import Budget, uncertainty_budget
from estimation.uncertainty.sources import Chain
from estimation.uncertainty.tow_refits import TowRefits


@dataclass(frozen=True)
class PlannedRun:
    """One planned step: ``drive`` in N (surge) or N·m (yaw) from ``hung_mass_kg``."""

    axis: str
    drive: float
    hung_mass_kg: float
    travel: float  # m or rad: the run ends here (end of travel, cord unwound)
    max_time_s: float
    repeats: int = 1


@dataclass(frozen=True)
class PlannedRig:
    """How the rig will record: its constants, sample rate, encoder step per axis, the
    release instant's σ."""

    chain: Chain
    rate_hz: float
    position_step: Mapping[str, float]
    release_std_s: float = 0.002
    baseline_s: float = 1.0


def _drive_inertia(axis: str, chain: Chain) -> float:
    if axis == "surge":
        return chain.pulley_inertia_kg_m2 / chain.pulley_radius_m**2 if chain.pulley_radius_m else 0
    return chain.drum_inertia_kg_m2


def simulate_planned(
    run: PlannedRun, model: Sequence[float], rig: PlannedRig, run_id: str, rng: np.random.Generator
) -> RunData:
    """One planned run recorded by the simulated encoder (solve_ivp, module docstring)."""
    inertia, k_l, k_q = model
    drum = rig.chain.drum_radius_m if run.axis == "yaw" else None
    weight = run.hung_mass_kg * (1.0 if run.axis == "surge" else (drum or 0.0) ** 2)
    total = inertia + weight + _drive_inertia(run.axis, rig.chain)
    travel = run.travel
    sign = math.copysign(1.0, run.drive)

    def rhs(_: float, y: np.ndarray) -> list[float]:
        return [y[1], (run.drive - k_l * y[1] - k_q * abs(y[1]) * y[1]) / total]

    def end(_: float, y: np.ndarray) -> float:
        return travel - sign * y[0]

    end.terminal = True  # type: ignore[attr-defined]
    from scipy.integrate import solve_ivp  # here: the service imports this module for its
    # request types, and never plans in its own process

    sol = solve_ivp(
        rhs, (0, run.max_time_s), [0, 0], events=end, dense_output=True, rtol=1e-9, atol=1e-12
    )
    stop = float(sol.t[-1])
    dt = 1.0 / rig.rate_hz
    t = np.arange(0.0, rig.baseline_s + stop, dt)
    x = np.where(t > rig.baseline_s, sol.sol(np.clip(t - rig.baseline_s, 0, stop))[0], 0.0)
    step = rig.position_step[run.axis]
    x = np.round((x + rng.normal(0, step / 3, t.size)) / step) * step
    return RunData(
        run_id,
        run.axis,  # type: ignore[arg-type]
        t,
        x,
        run.drive,
        hung_mass_kg=run.hung_mass_kg,
        drive_inertia=_drive_inertia(run.axis, rig.chain),
        drum_radius_m=drum,
        t_release=rig.baseline_s,
        t_release_std=rig.release_std_s,
    )


def predict_uncertainty(
    planned: Sequence[PlannedRun],
    models: Mapping[str, Sequence[float]],
    rig: PlannedRig,
    tolerances: Mapping[str, float] | None,
    seed: int = 0,
) -> dict[str, Budget]:
    """The budget each axis of the plan will reach: {axis: Budget} (module docstring).
    ``models``: (M, K_L, K_Q) per axis, the current estimate."""
    rng = np.random.default_rng(seed)
    out = {}
    for axis in sorted({p.axis for p in planned}):
        if axis not in models:
            raise FieldError("model", axis, f"a current model for {axis} (a stored estimate)")
        runs = [
            simulate_planned(p, models[axis], rig, f"plan-{i}-{k}", rng)
            for i, p in enumerate(planned)
            if p.axis == axis
            for k in range(p.repeats)
        ]
        result = estimate(runs, search_effects=False, n_bootstrap=0)
        out[axis] = uncertainty_budget(
            result, TowRefits(runs, result, rig.chain), tolerances, result.repeats
        )
    return out
