"""Time of a full sensitivity analysis (S, knock-out, ±σ, threshold sweep, identifiability)
of the fixture vehicles with every response they can do.

Prints one JSON document. The API runs the analysis in the request when it stays under
~2 s (api/http/routes/analysis.py). Run: .venv/bin/python bench/sensitivity_speed.py
"""

from __future__ import annotations

import json
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import numpy as np

from estimation.vehicle.identifiability import analyse_identified
from estimation.vehicle.vehicle_file import load_vehicle

VEHICLES = Path(__file__).resolve().parents[1] / "fixtures" / "vehicles"
#: A surge result as stored by the estimator (BENBAM's seed-000 values, 2–5 % σ), so the
#: ±σ cases and the identifiability part are timed too.
SURGE_RESULT = {
    "axis": "surge",
    "coefficients": {
        "inertia": {"value": 143.26, "std": 3.0},
        "linear_damping": {"value": 20.16, "std": 1.0},
        "quadratic_damping": {"value": 241.14, "std": 8.0},
    },
    "correlation": {
        "names": ["inertia", "linear_damping", "quadratic_damping"],
        "matrix": [[1.0, -0.6, 0.3], [-0.6, 1.0, -0.94], [0.3, -0.94, 1.0]],
    },
}


def _timed(name: str, results: list, repeats: int) -> dict:
    vehicle = load_vehicle(VEHICLES / f"{name}.toml")
    times, report = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        report = analyse_identified(vehicle, results)
        times.append(time.perf_counter() - t0)
    assert report is not None
    return {
        "median_s": float(np.median(times)),
        "max_s": float(np.max(times)),
        "repeats": repeats,
        "simulations": report.simulations,
        "responses": [r.name for r in report.plan.responses],
        "sweep_rows": len(report.sweep),
    }


def main() -> None:
    cases = {
        "seed002-rov": _timed("seed002-rov", [], 5),
        "benbam": _timed("benbam", [], 5),
        "benbam_with_surge_result": _timed("benbam", [SURGE_RESULT], 5),
    }
    print(
        json.dumps(
            {
                "benchmark": "sensitivity_speed",
                "python": platform.python_version(),
                "machine": platform.machine(),
                "cases": cases,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
