"""Time of each pendulum method and of the effect search on a 60 s free decay at 10 Hz.

Prints one JSON document (median and max over repeats, seconds). The record comes from
the tests' independent integrator (solve_ivp), once clean and once with pivot dry friction.
Run: .venv/bin/python bench/pendulum_speed.py
"""

from __future__ import annotations

import json
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from bench.timing import timed
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.output_error_fit import fit_motion
from estimation.pendulum.configuration import CANDIDATES, PIVOT_DOF, SETUP
from estimation.pendulum.methods import damped_fit, equation_error, log_decrement
from estimation.pendulum.pendulum_estimate import estimate_pendulum
from estimation.pendulum.swing_extrema import find_peaks, prepare_decay
from tests.estimation.pendulum_synth import ALPHA, BETA, decay


def main() -> None:
    out: dict = {"record": "60 s after release at 10 Hz (601 samples)", "cases": {}}
    for label, tau in (("clean", 0.0), ("coulomb_friction", 0.4)):
        run = decay(dry_friction=tau, duration=60.0)
        d = prepare_decay(run)
        peaks = find_peaks(d)
        start = np.array([ALPHA, BETA, 0.0, d.phi[0], 0.0])  # α, β, offset, φ₀, φ̇₀
        records = [d.record()]
        out["cases"][label] = {
            "find_peaks": timed(lambda d=d: find_peaks(d), 20),
            "damped-fit": timed(lambda d=d, p=peaks: damped_fit(d, p), 20),
            "log-decrement": timed(lambda d=d, p=peaks: log_decrement(d, p), 20),
            "equation-error": timed(lambda d=d, p=peaks: equation_error(d, p), 20),
            "output-error (base fit)": timed(
                lambda r=records, s=start: fit_motion(r, SETUP, start=s), 5
            ),
            "one engine (window, search, rules)": timed(
                lambda r=records: estimate_records(
                    r, PIVOT_DOF, restoring_known=True, candidates=CANDIDATES
                ),
                3,
            ),
            "estimate_pendulum (all)": timed(lambda r=run: estimate_pendulum([r]), 3),
        }
    out["python"] = platform.python_version()
    out["machine"] = platform.machine()
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
