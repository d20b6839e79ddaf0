"""What the calibration uncertainty and the cross-check cost.

Two thruster-driven surge runs (6 s at 10 Hz) with 30 drive draws: the estimation with
σ_cal (30 refits of the final model) against the same runs without draws, and the
cross-check of two stored result documents (no fitting). Prints one JSON document.
Run: .venv/bin/python bench/crosscheck_speed.py
"""

from __future__ import annotations

import json
import platform
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from bench.timing import timed
from estimation import estimate
from estimation.axis.drive_crosscheck import cross_check
from estimation.thrust.curve import ThrustCurve
from estimation.thrust.drive import DRIVE_DRAWS, curve_draws
from tests.estimation.synth import SURGE_TRUTH, Physics, thruster_run, tow_set


def main() -> None:
    values = np.array([50.0, 0.05, 0.8, 39.0, 0.05, 0.8, 0.0])
    std = values * 0.01
    curve = ThrustCurve(values, std, np.eye(7), 0.05, -0.8, 0.8)
    draws = curve_draws(curve, DRIVE_DRAWS)
    runs = []
    for f in (20.0, 45.0):
        run = thruster_run(Physics(*SURGE_TRUTH), (f,), hold_s=6.0, run_id=f"thr-{f:g}")
        command = curve.command_for_force(run.drive / 2)
        runs.append(replace(run, drive_draws=np.array([2 * c.force(command) for c in draws])))
    bare = [replace(r, drive_draws=None) for r in runs]
    weight_doc = estimate(tow_set(drives=(24.5, 83.3)), n_bootstrap=0).to_json()
    thruster_doc = estimate(runs, n_bootstrap=0).to_json()
    cases = {
        "estimate_2_thruster_runs_without_draws": timed(
            lambda: estimate(bare, n_bootstrap=0, search_effects=False), 3
        ),
        f"estimate_2_thruster_runs_with_{DRIVE_DRAWS}_draws": timed(
            lambda: estimate(runs, n_bootstrap=0, search_effects=False), 3
        ),
        "cross_check_of_two_result_documents": timed(
            lambda: cross_check(weight_doc, thruster_doc), 50
        ),
    }
    print(
        json.dumps(
            {"python": platform.python_version(), "machine": platform.machine(), "cases": cases},
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
