"""What the analysis route and ``rig sensitivity`` share: stored estimation results with
their runs' speeds, AHP weights from judgement matrices, and one analysis call."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from api.core.sensitivity_request import SensitivityRequest
from api.core.sixdof import stored_estimates
from api.core.vehicle_files import find_vehicle
from daq.run_data import load_run_data
from daq.store import Store
from estimation.vehicle.ahp import Hierarchy, Judgement, hierarchy, judge
from estimation.vehicle.identifiability import analyse_identified, run_speed


def stored_results(
    store: Store, result_ids: Sequence[int]
) -> tuple[list[dict[str, Any]], dict[str, list[float]]]:
    """Estimation result documents (with ``result_id``) and, per axis, the end speeds of
    the runs behind them. ``ResultNotFound`` names an unknown id; a calibration result is
    a ValueError naming it."""
    docs: list[dict[str, Any]] = []
    speeds: dict[str, list[float]] = {}  # axis → end speeds, m/s or rad/s
    for found in stored_estimates(store, result_ids):
        doc = dict(found.data) | {"result_id": found.id}
        docs.append(doc)
        for run_id in found.run_ids:
            try:
                speeds.setdefault(doc["axis"], []).append(run_speed(load_run_data(store, run_id)))
            except (KeyError, ValueError):  # run gone or not estimable: σ and ρ still speak
                continue
    return docs, speeds


def judgement(spec: Mapping[str, Any]) -> Judgement | Hierarchy:
    """AHP from ``{"criteria": {name, matrix, labels}, "groups": [{name, matrix, labels}]}``
    (a two-level hierarchy) or ``{"matrix", "labels", "name"}`` (one matrix)."""
    if spec.get("groups"):
        crit = spec.get("criteria") or {}
        groups = spec["groups"]
        return hierarchy(
            crit.get("matrix"),
            [(g.get("matrix"), g.get("labels") or []) for g in groups],
            criteria_name=crit.get("name") or "criteria",
            group_names=[g.get("name") or f"group{i}" for i, g in enumerate(groups)],
        )
    return judge(spec.get("matrix"), spec.get("name") or "matrix", labels=spec.get("labels"))


def analyse_vehicle(
    store: Store | None,
    request: SensitivityRequest,
    *,
    allow_path: bool = False,
    max_evaluations: int | None = None,
    time_limit_s: float | None = None,
) -> dict[str, Any]:
    """The full analysis ``request`` asks for, of a vehicle (with stored estimates plugged
    in), as JSON; ``allow_path``: the vehicle may be a file's path (the command line)."""
    if request.weights and request.ahp:
        raise ValueError("weights: give either weights or ahp judgement matrices, not both")
    vehicle_name, estimates = request.vehicle, request.estimates
    vehicle = find_vehicle(vehicle_name, allow_path=allow_path)
    if estimates and store is None:
        raise ValueError("estimates: stored results need a database")
    docs, speeds = stored_results(store, estimates) if store and estimates else ([], {})
    ahp = request.ahp.model_dump(exclude_none=True) if request.ahp else None
    chosen = judgement(ahp) if ahp else request.weights
    report = analyse_identified(
        vehicle,
        docs,
        run_speeds=speeds,
        responses=request.responses,
        weights=chosen,
        delta=request.delta,
        thresholds=request.thresholds,
        keep=request.keep,
        forces=request.forces,
        distance_time_s=request.distance_time_s,
        max_evaluations=max_evaluations,
        time_limit_s=time_limit_s,
    )
    out = report.to_json()
    out["vehicle_name"] = vehicle_name
    out["estimates"] = [
        {"result_id": d["result_id"], "axis": d["axis"], "runs": d.get("runs", [])} for d in docs
    ]
    out["run_speeds"] = speeds
    return out
