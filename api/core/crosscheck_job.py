"""Cross-check on stored results or runs: compare, store (kind ``crosscheck``), report.

Shared by ``rig crosscheck`` and the HTTP API so both give the same JSON; what each takes is
``api.core.crosscheck_requests``'.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from api.core.estimation_job import run_estimation
from api.core.rig_envelope import envelope_of_runs
from daq.store import ResultNotFound, RunNotFound, Store
from daq.store.run_events import RunEvents
from estimation.axis.drive_crosscheck import cross_check


def _estimation(store: Store, result_id: int, field: str) -> dict[str, Any]:
    try:
        result = store.result(result_id)
    except ResultNotFound:
        raise ValueError(f"{field}: {result_id!r} is not allowed; no result with that id") from None
    if result.kind != "estimation":
        raise ValueError(
            f"{field}: result #{result_id} is a {result.kind} result; allowed: an estimation"
        )
    return result.data | {"result_id": result.id}


def supply_voltages(store: Store, thruster_result: dict[str, Any]) -> dict[str, float | None]:
    """Mean supply voltage at calibration (thrusting steps of the calibration the runs used)
    and while the thruster-driven runs drove (samples after the thrust went on), V."""
    calibration_ids: set[int] = set()  # the thrust calibrations the runs used
    volts: list[float] = []
    for run_id in thruster_result.get("runs", []):
        try:
            run = store.get_run(run_id)
        except RunNotFound:
            continue
        params = run.parameters or {}
        if params.get("drive") != "thrusters":
            continue
        calibration_id = params.get("calibration_result_id")
        if calibration_id is not None:
            calibration_ids.add(calibration_id)
        table = store.samples(run.id)
        channel = table.channels.get("supply_voltage")
        events = RunEvents.of(store.events(run.id))
        release = events.release_time
        brake = None if events.brake is None else events.brake.t_last_free
        if channel is None or release is None:
            continue
        on = table.t_mono > release + 0.5  # past the ramp
        if brake is not None:
            on &= table.t_mono <= brake
        good = on & np.isfinite(channel)
        if good.any():
            volts.append(float(np.mean(channel[good])))
    at_calibration = []
    for cid in calibration_ids:
        try:
            rows = store.result(cid).data.get("table", [])
        except ResultNotFound:
            continue
        at_calibration += [
            r["supply_voltage_v"]
            for r in rows
            if r.get("command") and r.get("supply_voltage_v") is not None
        ]
    return {
        "calibration": float(np.mean(at_calibration)) if at_calibration else None,
        "runs": float(np.mean(volts)) if volts else None,
    }


def crosscheck_results(
    store: Store,
    weight_result_id: int,
    thruster_result_id: int,
    *,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Cross-check two stored estimation results (no fitting); store it linked to the runs
    of both and return its JSON with ``result_id``. Stored results never change, so a pair
    already cross-checked returns that result (``reused: true``) instead of storing the same
    comparison again. ``ValueError`` names a bad field."""
    from estimation.axis.crosscheck_report import write_crosscheck_report

    weight = _estimation(store, weight_result_id, "weight_result_id")
    thrusters = _estimation(store, thruster_result_id, "thruster_result_id")
    records = [store.get_run(r) for r in (*weight.get("runs", []), *thrusters.get("runs", []))]
    check = cross_check(
        weight,
        thrusters,
        supply_voltage_v=supply_voltages(store, thrusters),
        envelope=envelope_of_runs(store, records),
    )
    data = check.to_json()
    if report_dir is not None:
        data["report_files"] = [str(p) for p in write_crosscheck_report(check, Path(report_dir))]
    pair = (weight["result_id"], thrusters["result_id"])
    for earlier in reversed(store.results(kind="crosscheck")):
        if (earlier.data.get("weight_result_id"), earlier.data.get("thruster_result_id")) == pair:
            return data | {"result_id": earlier.id, "reused": True}
    runs = list(dict.fromkeys([*weight.get("runs", []), *thrusters.get("runs", [])]))
    stored = {k: v for k, v in data.items() if k != "report_files"}  # no scratch paths
    data["result_id"] = store.add_result(runs, "crosscheck", stored)
    return data


def crosscheck_runs(
    store: Store,
    weight_runs: Sequence[str],
    thruster_runs: Sequence[str],
    *,
    search_effects: bool = True,
    report_dir: str | Path | None = None,
) -> dict[str, Any]:
    """Estimate both sets of runs (each stored as an estimation result), then cross-check.

    Returns the cross-check JSON with ``weight_estimation`` and ``thruster_estimation``
    (the two estimation documents) added.
    """
    if not weight_runs:
        raise ValueError("weight_runs: give at least one weight-driven run id")
    if not thruster_runs:
        raise ValueError("thruster_runs: give at least one thruster-driven run id")
    folder = Path(report_dir) if report_dir is not None else None
    weight = run_estimation(
        store,
        weight_runs,
        search_effects=search_effects,
        report_dir=folder / "weight" if folder else None,
    )
    thrusters = run_estimation(
        store,
        thruster_runs,
        search_effects=search_effects,
        report_dir=folder / "thrusters" if folder else None,
    )
    data = crosscheck_results(store, weight["result_id"], thrusters["result_id"], report_dir=folder)
    return data | {"weight_estimation": weight, "thruster_estimation": thrusters}
