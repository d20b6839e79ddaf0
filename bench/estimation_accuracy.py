"""Accuracy of each estimation method side by side on the same simulated runs.

Four weight-driven runs per axis (seed 000's forces/torques, its approach-3 coefficients as
truth, hung weight declared), 10 Hz with 2 ms timestamp jitter, encoder steps q = 0.1, 0.5,
1 mm (or mrad), 10 seeds each. Prints one JSON document: per axis, q and method, the mean
and worst relative error of each coefficient and how often the truth lies within ±2σ.
Run: .venv/bin/python bench/estimation_accuracy.py [--seeds N]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from estimation import METHODS, estimate
from tests.estimation.synth import SURGE_TRUTH, YAW_TRUTH, tow_set

NAMES = ("inertia", "linear_damping", "quadratic_damping")
QUANTA = (1e-4, 5e-4, 1e-3)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    t0 = time.perf_counter()
    out: dict = {"benchmark": "estimation_accuracy", "seeds": args.seeds, "axes": {}}
    for axis, truth in (("surge", SURGE_TRUTH), ("yaw", YAW_TRUTH)):
        truth_arr = np.array(truth)
        per_q = {}
        for q in QUANTA:
            values = {m: [] for m in METHODS}
            stds = {m: [] for m in METHODS}
            for seed in range(args.seeds):
                runs = tow_set(axis=axis, seed=500 + seed, quantum=q)
                for m in METHODS:
                    res = estimate(runs, method=m, search_effects=False, n_bootstrap=0)
                    values[m].append([res.coefficients[n].value for n in NAMES])
                    stds[m].append([res.coefficients[n].std for n in NAMES])
            table = {}
            for m in METHODS:
                v, s = np.array(values[m]), np.array(stds[m])
                rel = np.abs(v / truth_arr - 1)
                inside = np.abs(v - truth_arr) <= 2 * s
                table[m] = {
                    n: {
                        "mean_value": float(v[:, i].mean()),
                        "mean_rel_error": float(rel[:, i].mean()),
                        "worst_rel_error": float(rel[:, i].max()),
                        "mean_reported_std": float(s[:, i].mean()),
                        "truth_within_2sigma": float(inside[:, i].mean()),
                    }
                    for i, n in enumerate(NAMES)
                }
            per_q[f"{q * 1e3:g}mm"] = table
        out["axes"][axis] = {"truth": dict(zip(NAMES, truth, strict=True)), "quantum": per_q}
    out["elapsed_s"] = time.perf_counter() - t0
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
