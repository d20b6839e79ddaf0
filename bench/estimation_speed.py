"""Time of a joint 4-run output-error fit (4 × 30 s at 10 Hz) and of a full effect search.

The search tries every single effect and every pair (and extends a winning pair); the
"pair" case needs two effects at once (dry friction and a current, reverse runs in the set),
the "outside_library" case a force periodic along the rail that must be flagged, not fitted;
the "decay" cases a free heave decay through ``estimate_decay``, the "pendulum" cases a
60 s pendulum swing (clean, and with pivot dry friction) through ``estimate_pendulum``
(the decay's engine with the pendulum's methods beside it): the bench times every kind.
Prints one JSON document. Targets: joint fit < 0.2 s; effect search with pairs ≤ 1 s on a
quiet machine (floor 3 s). ``cpu_median_s`` is CPU time, for a machine that is not quiet
(``effect_search_cpu_met``). The estimator runs its fits on one BLAS thread
(``estimation/blas_threads.py``): OpenBLAS's worker threads only spun on these small problems.
Run: .venv/bin/python bench/estimation_speed.py
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from bench.timing import timed
from estimation import estimate
from estimation.axis.output_error import fit_output_error
from estimation.axis.prepared_run import prepare
from estimation.motion.decay_estimate import estimate_decay
from estimation.pendulum.pendulum_estimate import estimate_pendulum
from tests.estimation.pendulum_synth import decay as pendulum_decay
from tests.estimation.synth import SURGE_TRUTH, Physics, tow_set


def decay_records() -> dict[str, tuple[np.ndarray, np.ndarray, dict]]:
    """A heave decay of a 143 kg body (+ 114 kg added, ρ·g·A_w = 5720 N/m) from 0.05 m,
    15 s at 20 Hz, 20 µm noise: clean, and with quadratic damping (RK4 at 1 kHz here)."""
    out = {}
    total, k, b1 = 257.4, 5720.0, 72.8
    for name, b2 in (("clean", 0.0), ("quadratic_damping", 572.0)):
        dt, n = 1e-3, 15000
        x, v, xs = 0.05, 0.0, []
        acc = lambda x, v, b2=b2: -(b1 * v + b2 * abs(v) * v + k * x) / total  # noqa: E731
        for i in range(n):
            if i % 50 == 0:
                xs.append(x)
            a1 = acc(x, v)
            a2 = acc(x + dt / 2 * v, v + dt / 2 * a1)
            a3 = acc(x + dt / 2 * (v + dt / 2 * a1), v + dt / 2 * a2)
            a4 = acc(x + dt * (v + dt / 2 * a2), v + dt * a3)
            x, v = (
                x + dt * v + dt * dt / 6 * (a1 + a2 + a3),
                v + dt / 6 * (a1 + 2 * a2 + 2 * a3 + a4),
            )
        t = np.arange(len(xs)) / 20.0
        noisy = np.array(xs) + 2e-5 * np.random.default_rng(1).standard_normal(len(xs))
        out[name] = (t, noisy, {"known_inertia": 143.0, "stiffness": k})
    return out


def main() -> None:
    # 4 × 30 s at 10 Hz: the rail limit is lifted so every tow lasts the full 30 s
    clean = tow_set(seed=1, duration_s=30.0, travel_limit=1e3)
    samples = [int(np.count_nonzero(r.t > r.t_release)) for r in clean]
    prepared = [prepare(r) for r in clean]
    cases = {
        "joint_fit_4x30s_closed_form": timed(lambda: fit_output_error(prepared), 20),
        "joint_fit_4x30s_integrated": timed(lambda: fit_output_error(prepared, ("cubic_drag",)), 5),
        "estimate_no_search_no_bootstrap": timed(
            lambda: estimate(clean, search_effects=False, n_bootstrap=0), 10
        ),
    }
    searches = {
        "clean": clean,
        "coulomb_friction": tow_set(Physics(*SURGE_TRUTH, coulomb=3.0), seed=1, travel_limit=1e3),
        "restoring_spring": tow_set(Physics(*SURGE_TRUTH, spring=1.0), seed=1, travel_limit=1e3),
        "cubic_drag": tow_set(Physics(*SURGE_TRUTH, cubic=150.0), seed=1, travel_limit=1e3),
        "pair_coulomb_and_current": tow_set(
            Physics(*SURGE_TRUTH, coulomb=2.0, bias=-1.0),
            seed=1,
            travel_limit=1e3,
            drives=(24.5, -44.1, 83.3, -4.9),
        ),
        "outside_library": tow_set(Physics(*SURGE_TRUTH, ripple=2.0), seed=1, travel_limit=1e3),
    }
    for name, runs in searches.items():
        found = [e.name for e in estimate(runs, n_bootstrap=0).effects]

        def search(runs: list = runs) -> object:
            return estimate(runs, n_bootstrap=0)

        entry = timed(search, 3)
        entry["effects_found"] = found
        cases[f"full_effect_search_{name}"] = entry
    for name, (t, x, known) in decay_records().items():

        def decay(t: np.ndarray = t, x: np.ndarray = x, known: dict = known) -> object:
            return estimate_decay(t, x, "heave", **known)

        found = list(estimate_decay(t, x, "heave", **known).effect_names)
        entry = timed(decay, 3)
        entry["effects_found"] = found
        cases[f"full_effect_search_decay_{name}"] = entry
    for name, tau in (("clean", 0.0), ("coulomb_friction", 0.4)):
        swing = pendulum_decay(dry_friction=tau, duration=60.0)
        found = [e.name for e in estimate_pendulum([swing]).effects]

        def pendulum(run: object = swing) -> object:
            return estimate_pendulum([run])

        entry = timed(pendulum, 3)
        entry["effects_found"] = found
        cases[f"full_effect_search_pendulum_{name}"] = entry
    cases["estimate_with_40_bootstrap_clean"] = timed(lambda: estimate(clean), 3)
    searches_run = [v for k, v in cases.items() if k.startswith("full_effect")]
    worst_search = max(v["median_s"] for v in searches_run)
    worst_cpu = max(v["cpu_median_s"] for v in searches_run)
    print(
        json.dumps(
            {
                "benchmark": "estimation_speed",
                "python": platform.python_version(),
                "runs": len(clean),
                "samples_after_release_per_run": samples,
                "cases": cases,
                "targets": {
                    "joint_fit_s": 0.2,
                    "joint_fit_met": cases["joint_fit_4x30s_closed_form"]["median_s"] < 0.2,
                    "effect_search_s": 1.0,
                    "effect_search_floor_s": 3.0,
                    "worst_search_wall_s": worst_search,
                    "worst_search_cpu_s": worst_cpu,
                    "effect_search_met": worst_search <= 1.0,
                    "effect_search_cpu_met": worst_cpu <= 1.0,
                    "effect_search_floor_met": worst_search <= 3.0,
                },
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
