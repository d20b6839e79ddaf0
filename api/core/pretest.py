"""Pre-test uncertainty of a planned sequence (``rig predict-uncertainty``, ``POST
/api/uncertainty/predict``): the sequence checked against the rig file, each axis's current
model taken from the newest stored output-error estimate (or the results named), and
``estimation.uncertainty.pretest`` run on plain numbers."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from daq.axis_budget import chain_of, tolerances_of
from daq.config import RigConfig
from daq.procedures.requests import SpinRequest as SpinParameters
from daq.procedures.requests import TowRequest as TowParameters
from daq.procedures.sequence import load_sequence
from daq.store import Store
from estimation.uncertainty.pretest import PlannedRig, PlannedRun, predict_uncertainty

#: Release instant σ assumed when no stored run says otherwise, s: the brake write's
#: bracket on the simulated rig's Modbus (a few ms); ``release_std_s`` overrides it.
DEFAULT_RELEASE_STD_S = 0.002


def current_models(store: Store, result_ids: Sequence[int] = ()) -> dict[str, list[float]]:
    """(M, K_L, K_Q) per axis from the named results, else the newest output-error estimate
    of each axis."""
    found = (
        [store.result(i) for i in result_ids] if result_ids else store.results(kind="estimation")
    )
    models: dict[str, list[float]] = {}
    for info in found:
        data = info.data
        if data.get("method") != "output-error" or "coefficients" not in data:
            continue
        c = data["coefficients"]
        models[data["axis"]] = [
            c[n]["value"] for n in ("inertia", "linear_damping", "quadratic_damping")
        ]
    return models


def planned_runs(rig: RigConfig, sequence_path: str | Path) -> list[PlannedRun]:
    """The weight-driven tows and spins of a sequence file (other steps are not predicted)."""
    seq = load_sequence(sequence_path, rig)
    out = []
    for step in seq.steps:
        # checked parameters: the load and the rig's limits are set
        if isinstance(step, TowParameters) and step.drive == "weight" and step.hung_mass_kg:
            assert step.force_n is not None and step.max_distance_m is not None
            assert step.max_time_s is not None
            out.append(
                PlannedRun(
                    "surge",
                    step.force_n,
                    step.hung_mass_kg,
                    step.max_distance_m,
                    step.max_time_s,
                    seq.repeats,
                )
            )
        elif isinstance(step, SpinParameters) and step.drive == "weight" and step.hung_mass_kg:
            assert step.torque_nm is not None and step.max_angle_rad is not None
            assert step.max_time_s is not None
            out.append(
                PlannedRun(
                    "yaw",
                    step.torque_nm,
                    step.hung_mass_kg,
                    step.max_angle_rad,
                    step.max_time_s,
                    seq.repeats,
                )
            )
    if not out:
        raise ValueError(
            f"sequence: got {sequence_path}, allowed: a sequence with weight-driven tows or spins"
        )
    return out


def predict_sequence(
    store: Store,
    rig: RigConfig,
    sequence_path: str | Path,
    result_ids: Sequence[int] = (),
    release_std_s: float = DEFAULT_RELEASE_STD_S,
) -> dict[str, Any]:
    """{"sequence", "models", "tolerances", "axes": {axis: budget JSON}} of the plan."""
    if not 0 <= release_std_s <= 1:
        raise ValueError(f"release_std_s: got {release_std_s}, allowed: 0 … 1 s")
    planned = planned_runs(rig, sequence_path)
    models = current_models(store, result_ids)
    missing = sorted({p.axis for p in planned} - set(models))
    if missing:
        raise ValueError(
            f"model: got no stored estimate for {', '.join(missing)}, allowed: a stored "
            "output-error estimate of each axis the sequence drives (estimate a first campaign, "
            "or name results with --result)"
        )
    steps = {
        "surge": abs(rig.channel("tow_position").scale) if rig.has("tow_position") else 1e-4,
        "yaw": abs(rig.channel("yaw_angle").scale) if rig.has("yaw_angle") else 1e-4,
    }
    planned_rig = PlannedRig(
        chain_of(rig), rig.acquisition.rate_hz, steps, release_std_s=release_std_s
    )
    tolerances = tolerances_of(rig)
    budgets = predict_uncertainty(planned, models, planned_rig, tolerances)
    return {
        "sequence": str(sequence_path),
        "models": models,
        "tolerances": tolerances,
        "release_std_s": release_std_s,
        "axes": {axis: b.to_json() for axis, b in budgets.items()},
    }
