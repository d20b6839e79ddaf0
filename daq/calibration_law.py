"""Stored thrust calibrations as thrust laws: import a thrust-stand table, and find the law
of an imported table or of a calibration run (``rig calibrate-thrusters``).

An imported calibration may cover several supply voltages (the law is identified from
them); a calibration run is one voltage (the mean supply voltage it recorded), so its
voltage law is assumed (``estimation.thrust.law``).
"""

from __future__ import annotations

from typing import Any

from daq.store import ResultNotFound, Store
from daq.store.calibrations import CalibrationNotFound
from estimation.thrust.calibration_import import STAND_UNITS, ImportSpec, read_calibration_csv
from estimation.thrust.curve import ThrustCurve
from estimation.thrust.law import VOLTAGE_TOLERANCE_V, ThrustLaw, identify_thrust_law

#: Where a calibration comes from: an imported table or a calibration run's result.
SOURCES = ("imported", "run")


#: Laws already identified, by (source, id): a stored calibration never changes.
_LAWS: dict[tuple[str, int], ThrustLaw] = {}
_LAWS_KEPT = 16


def _cached(source: str, key: int, build) -> ThrustLaw:
    law = _LAWS.get((source, key))
    if law is None:
        law = build()
        if len(_LAWS) >= _LAWS_KEPT:
            _LAWS.pop(next(iter(_LAWS)))
        _LAWS[(source, key)] = law
    return law


class NoCalibration(LookupError):
    """No thrust calibration stored (or not the one asked for)."""


def import_calibration(store: Store, data: bytes | str, spec: ImportSpec, name: str) -> dict:
    """Read a thrust-stand table, identify its thrust law (refusing a table it cannot fit)
    and store it; returns ``{id, name, rows, law}``."""
    table = read_calibration_csv(data, spec)
    law = identify_thrust_law(table)
    record = {
        "source": name,
        "units": {
            "command": spec.command.to_json(),
            "thrust": spec.thrust_unit,
            "voltage_column": spec.voltage_column,
            "voltage_v": spec.voltage_v,
            "stand": STAND_UNITS,
        },
        "table": table,
    }
    calibration_id = store.add_calibration(name, record)
    kept = [c for c in STAND_UNITS if c in table[0]]
    return {
        "id": calibration_id,
        "name": name,
        "rows": len(table),
        "channels": kept,
        "law": law.to_json(),
    }


def at_reference_voltage(table: list[dict], law: ThrustLaw) -> tuple[ThrustCurve, list[dict]]:
    """The law's curve at its reference voltage and the rows measured there (rows without a
    voltage included): what a drive at one voltage is computed and checked with."""
    rows = [
        r
        for r in table
        if r.get("supply_voltage_v") is None
        or abs(float(r["supply_voltage_v"]) - law.reference_voltage) <= VOLTAGE_TOLERANCE_V
    ]
    return law.curves[-1].curve, rows


def _run_table(table: list[dict]) -> tuple[list[dict], float | None]:
    """A calibration run's table as one voltage: its mean recorded supply voltage."""
    volts = [float(r["supply_voltage_v"]) for r in table if r.get("supply_voltage_v") is not None]
    mean = sum(volts) / len(volts) if volts else None
    rows = [
        {
            "command": r["command"],
            "thrust_per_thruster_n": r["thrust_per_thruster_n"],
            "supply_voltage_v": mean,
        }
        for r in table
    ]
    return rows, mean


def law_of(
    store: Store, source: str | None = None, calibration_id: int | str | None = None
) -> tuple[ThrustLaw, dict[str, Any]]:
    """The thrust law of one stored calibration and what it is (``{source, id, name}``).

    ``source`` "imported" or "run" with ``calibration_id``; neither: the newest of both
    kinds. Raises ``NoCalibration`` naming what is missing."""
    if source is not None and source not in SOURCES:
        raise ValueError(f"source: got {source!r}, allowed: {', '.join(SOURCES)}")
    if calibration_id is not None and source is None:
        source = "imported"
    imported = run = None
    try:
        if source in (None, "imported"):
            imported = (
                store.latest_imported_calibration()
                if calibration_id is None
                else store.imported_calibration(calibration_id)
            )
        if source in (None, "run"):
            run = (
                store.latest_result("calibration")
                if calibration_id is None
                else store.result(calibration_id)
            )
            if run is not None and run.kind != "calibration":
                raise ResultNotFound(f"result {calibration_id} is not a thrust calibration")
    except (CalibrationNotFound, ResultNotFound) as err:
        raise NoCalibration(str(err)) from None
    if imported is not None and (run is None or imported.created_at >= run.created_at):
        law = _cached("imported", imported.id, lambda: identify_thrust_law(imported.data["table"]))
        return law, {
            "source": "imported",
            "id": imported.id,
            "name": imported.name,
            "label": f"imported {imported.id} ({imported.name})",
        }
    if run is not None:
        rows, _ = _run_table(run.data.get("table", []))
        law = _cached("run", run.id, lambda: identify_thrust_law(rows))
        short = run.run_ids[0][:8] if run.run_ids else str(run.id)
        return law, {
            "source": "run",
            "id": run.id,
            "name": f"calibration run {short}",
            "label": f"run {short}",
        }
    raise NoCalibration(
        "no thrust calibration stored: run `rig calibrate-thrusters` or "
        "`rig import-calibration FILE`"
    )
