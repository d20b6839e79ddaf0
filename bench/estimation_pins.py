"""What the estimator answers, pinned, so a change to the engine shows what it moved (JSON).

The engine merge (issue 31) replaces the tow and the decay engines layer by layer; each
layer must say how far it moved the answers. This prints every case's coefficients (value,
σ), the effects kept, the RMSE after the search and B_e(5°) where it has one, on

* the published records (``../shared/data/real``): the KVLCC2 roll decays 21337, 21338 and
  21340 by the decay route and 21337 by the pendulum route, ten Cate's settling sphere E1
  (to the wall) and the ship2d section in waves (its measured force as the drive);
* synthetic records from scipy's ``solve_ivp`` (``tests.estimation.term_cases``, never our
  integrator): tow sets at 10, 143 and 1000 kg, clean and with dry friction and reverse
  runs, and heave decays at the same scales, clean and with quadratic damping.

``--compare BEFORE.json`` adds, per case, the largest change of a coefficient in units of
its σ (before's) and relative, and whether the effects kept changed.
Run: .venv/bin/python bench/estimation_pins.py [--compare BEFORE.json] [--only kvlcc2 …]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from estimation import RunData, estimate  # noqa: E402
from estimation.motion.decay_estimate import estimate_decay  # noqa: E402
from estimation.pendulum.data import PendulumGeometry, PendulumRun  # noqa: E402
from estimation.pendulum.pendulum_estimate import estimate_pendulum  # noqa: E402
from tests.estimation import term_cases  # noqa: E402
from tests.support.shared_data import shared_file, tencate_e1  # noqa: E402

#: KVLCC2 1:68 (kvlcc2-roll-decay/README.md): I44 = Δ·KXX² [kg·m²], C44 = Δ·g·GM [N·m/rad].
I44, C44 = 115.74281, 821.96
#: The KVLCC2 model as the pendulum rig file kvlcc2-roll.toml writes it.
KVLCC2_AS_PENDULUM = dict(
    pivot_to_vehicle_m=1.0, rod_mass_kg=83.78795, rod_cg_m=1.0, rod_inertia_kg_m2=I44,
    vehicle_mass_kg=0.001, vehicle_inertia_kg_m2=0.0, buoyancy_kg=0.001,
    pivot_damping_nm_s=0.0, g=9.81,
)  # fmt: skip


def _coefficients(coefficients: dict[str, Any]) -> dict[str, list[float | None]]:
    def plain(x: float) -> float | None:
        return float(x) if x is not None and math.isfinite(x) else None

    return {n: [plain(c.value), plain(c.std)] for n, c in coefficients.items()}


def _be5(result: Any) -> float | None:
    be = result.equivalent_damping(np.deg2rad(5.0))
    return None if be is None else float(be.value)


def _tow_case(runs: list[RunData]) -> dict[str, Any]:
    r = estimate(runs, n_bootstrap=0)
    return {
        "coefficients": _coefficients(r.coefficients),
        "effects": sorted(e.name for e in r.effects),
        "rmse": float(r.rmse_after),
    }


def _decay_case(result: Any, be5: bool = False) -> dict[str, Any]:
    out = {
        "coefficients": _coefficients(result.coefficients),
        "effects": sorted(result.effect_names),
        "rmse": float(result.rmse_after),
    }
    if be5:
        out["be5"] = _be5(result)
    return out


def _kvlcc2(run: str) -> tuple[np.ndarray, np.ndarray]:
    d = pd.read_csv(shared_file("real", "kvlcc2-roll-decay", f"kvlcc2_roll_decay_{run}.csv"))
    return d.t.to_numpy(), d.position.to_numpy()


def _kvlcc2_decay(run: str) -> dict[str, Any]:
    t, phi = _kvlcc2(run)
    r = estimate_decay(t, phi, "roll", known_inertia=I44, stiffness=C44, run_id=run)
    return _decay_case(r, be5=True)


def _kvlcc2_pendulum() -> dict[str, Any]:
    t, phi = _kvlcc2("21337")
    swing = PendulumRun("21337", t, phi, 2.0, PendulumGeometry(**KVLCC2_AS_PENDULUM), axis="sway")
    r = estimate_pendulum([swing])
    return {
        "coefficients": _coefficients(r.coefficients),
        "effects": sorted(e.name for e in r.effects),
        "rmse": float(r.rmse_after),
        "be5": _be5(r),
    }


def _ship2d() -> dict[str, Any]:
    d = pd.read_csv(shared_file("real", "ship2d-regular-waves", "ship2d_3111_2_20Hz.csv"))
    run = RunData(
        "3111_2", "surge", d.t.to_numpy(), d.position.to_numpy(),
        drive=d.force_sway_N.to_numpy(), t_release=0.0,
    )  # fmt: skip
    return _tow_case([run])


def _tencate() -> dict[str, Any]:
    return _tow_case([tencate_e1(t_release=0.0, t_end=2.45)])


def _synthetic_tows(scale: str, reverse: bool = False, **physics: float) -> dict[str, Any]:
    return _tow_case(term_cases.tow_set(scale, 7, reverse=reverse, **physics))


def _synthetic_decay(scale: str, **physics: float) -> dict[str, Any]:
    t, x, truth = term_cases.decay(scale, 7, **physics)
    return _decay_case(
        estimate_decay(t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"])
    )


def cases() -> dict[str, Callable[[], dict[str, Any]]]:
    """Every pinned case by name (the published ones first)."""
    out: dict[str, Callable[[], dict[str, Any]]] = {
        f"kvlcc2_{run}_decay": partial(_kvlcc2_decay, run) for run in ("21337", "21338", "21340")
    }
    out["kvlcc2_21337_pendulum"] = _kvlcc2_pendulum
    out["tencate_e1_tow"] = partial(_tencate)
    out["ship2d_tow"] = _ship2d
    for scale in term_cases.SCALES:
        friction, value, _ = term_cases.tow_effect("coulomb_friction", scale)
        damping, b2 = term_cases.decay_effect("quadratic_damping", scale)
        out[f"tows_{scale}_clean"] = partial(_synthetic_tows, scale)
        out[f"tows_{scale}_coulomb"] = partial(_synthetic_tows, scale, True, **{friction: value})
        out[f"decay_{scale}_clean"] = partial(_synthetic_decay, scale)
        out[f"decay_{scale}_quadratic"] = partial(_synthetic_decay, scale, **{damping: b2})
    return out


def compare(now: dict[str, Any], before: dict[str, Any]) -> dict[str, Any]:
    """Per case present in both: the largest |Δ|/σ_before and |Δ|/|before| of a coefficient
    both have, and whether the kept effects changed."""
    out = {}
    for name, case in now.items():
        old = before.get(name)
        if old is None:
            continue
        in_sigma, relative = 0.0, 0.0
        for coef, (value, _) in case["coefficients"].items():
            was, sigma = old["coefficients"].get(coef, (None, None))
            if value is None or was is None:
                continue
            if sigma:
                in_sigma = max(in_sigma, abs(value - was) / sigma)
            if was:
                relative = max(relative, abs(value - was) / abs(was))
        out[name] = {
            "max_change_in_sigma": round(in_sigma, 4),
            "max_relative_change": float(f"{relative:.3g}"),
            "effects_changed": case["effects"] != old["effects"],
        }
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="A JSON this script printed before.")
    parser.add_argument("--only", nargs="*", help="Only cases whose name contains one of these.")
    opts = parser.parse_args()
    results: dict[str, Any] = {}
    for name, run in cases().items():
        if opts.only and not any(part in name for part in opts.only):
            continue
        start = time.process_time()
        results[name] = run() | {"cpu_s": round(time.process_time() - start, 3)}
    out: dict[str, Any] = {"benchmark": "estimation_pins", "cases": results}
    if opts.compare:
        out["compared_with"] = str(opts.compare)
        out["changes"] = compare(results, json.loads(opts.compare.read_text())["cases"])
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
