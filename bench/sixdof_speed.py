"""Time of one 6-DOF simulation (60 s simulated, output every 0.01 s) on the fixtures.

Prints one JSON document. Target: 60 s of simulated time in < 50 ms for constant inputs
(the sensitivity analysis calls ``simulate`` hundreds of times).
Run: .venv/bin/python bench/sixdof_speed.py
"""

from __future__ import annotations

import json
import math
import platform
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


from bench.timing import timed
from estimation.vehicle.simulation import simulate
from estimation.vehicle.vehicle_file import load_vehicle

VEHICLES = Path(__file__).resolve().parents[1] / "fixtures" / "vehicles"
TARGET_S = 0.05


def main() -> None:
    rov = load_vehicle(VEHICLES / "seed002-rov.toml")
    benbam = load_vehicle(VEHICLES / "benbam.toml")
    cases = {
        "rov_8_thrusters_constant_60s": lambda: simulate(rov, 60.0, commands=[0.5] * 8),
        "rov_yaw_and_heave_60s": lambda: simulate(
            rov, 60.0, commands=[-0.5, 0.5, -0.5, 0.5, 0.3, 0.3, 0.3, 0.3]
        ),
        "rov_force_all_axes_60s": lambda: simulate(rov, 60.0, force=[5, 3, 2, 0.2, 0.3, 0.5]),
        "benbam_turning_60s": lambda: simulate(benbam, 60.0, commands=[0.5, 0.1]),
        "benbam_rolled_start_60s": lambda: simulate(
            benbam, 60.0, commands=[0.3, 0.3], eta0=[0, 0, 0, 0.3, 0.1, 0]
        ),
        "benbam_sine_commands_callable_60s": lambda: simulate(
            benbam, 60.0, commands=lambda t: [0.4 * math.sin(0.5 * t), 0.3]
        ),
    }
    results = {name: timed(fn, 10) for name, fn in cases.items()}
    constant = [v["median_s"] for k, v in results.items() if "callable" not in k]
    print(
        json.dumps(
            {
                "benchmark": "sixdof_speed",
                "python": platform.python_version(),
                "machine": platform.machine(),
                "simulated_s": 60.0,
                "output_dt_s": 0.01,
                "cases": results,
                "target_s": TARGET_S,
                "worst_constant_input_median_s": max(constant),
                "meets_target": max(constant) < TARGET_S,
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
