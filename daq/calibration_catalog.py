"""Measured and imported thrust calibrations as one list of records, and the rig's measured
supply voltage.

A measured calibration is a calibration run's result (``rig calibrate-thrusters``); an imported
one is a thrust-stand table (``rig import-calibration``). Both are thrust laws the rig drives
with; a person tells them apart by ``source`` and ``label``: ``run fc3ab8ab`` names the run a
measured calibration came from (not its result's row number), ``imported 3 (T200-16V.csv)`` an
imported table. ``latest`` is the newest of either, as the thruster-driven tests use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from daq.calibration_law import at_reference_voltage, law_of
from daq.store import Store
from daq.store.calibrations import CalibrationInfo
from daq.store.run_records import ResultInfo
from estimation.thrust.calibration_import import STAND_UNITS

#: How many of the newest runs are searched for a recorded supply voltage.
SUPPLY_RUNS_SEARCHED = 20


def _summary(table: list[dict]) -> dict[str, Any]:
    volts = sorted({r["supply_voltage_v"] for r in table if r.get("supply_voltage_v") is not None})
    commands = [r["command"] for r in table]
    return {
        "rows": len(table),
        "voltages_v": volts,
        "command_range": [min(commands), max(commands)] if commands else None,
        "channels": [c for c in STAND_UNITS if any(c in r for r in table)],
    }


def imported_record(info: CalibrationInfo) -> dict[str, Any]:
    """One imported table as a catalog record (without its rows)."""
    return {
        "source": "imported",
        "id": info.id,
        "label": f"imported {info.id} ({info.name})",
        "name": info.name,
        "created_at": info.created_at.isoformat(),
        "run_ids": [],
    } | _summary(info.data.get("table", []))


def measured_record(result: ResultInfo) -> dict[str, Any]:
    """One calibration run's result as a catalog record (without its rows)."""
    run = result.run_ids[0][:8] if result.run_ids else "?"
    return {
        "source": "run",
        "id": result.id,
        "label": f"run {run}",
        "name": f"calibration run {run}",
        "created_at": result.created_at.isoformat(),
        "run_ids": list(result.run_ids),
    } | _summary(result.data.get("table", []))


def _newest_first(records: list[tuple[datetime, dict[str, Any]]]) -> list[dict[str, Any]]:
    return [r for _, r in sorted(records, key=lambda pair: pair[0], reverse=True)]


def calibrations(store: Store) -> list[dict[str, Any]]:
    """Every stored calibration, measured and imported, newest first."""
    found = [(c.created_at, imported_record(c)) for c in store.imported_calibrations()]
    found += [(r.created_at, measured_record(r)) for r in store.results(kind="calibration")]
    return _newest_first(found)


def latest(store: Store) -> dict[str, Any] | None:
    """The newest calibration of either source with its rows and the fitted curve at its
    reference voltage (``data.table``, ``data.fit``; an imported table also the rows at that
    voltage, ``data.reference_table``), or None when there is none."""
    run = store.latest_result("calibration")
    imported = store.latest_imported_calibration()
    if imported is not None and (run is None or imported.created_at >= run.created_at):
        law, _ = law_of(store, "imported", imported.id)
        table = imported.data["table"]
        curve, rows = at_reference_voltage(table, law)
        data = {
            "table": table,
            "fit": curve.to_json(),
            "reference_table": rows,
            "reference_voltage_v": law.reference_voltage,
            "law": law.to_json(),
            "units": imported.data.get("units"),
        }
        return imported_record(imported) | {
            "kind": "calibration",
            "software_version": imported.software_version,
            "data": data,
        }
    if run is None:
        return None
    return measured_record(run) | {
        "kind": "calibration",
        "software_version": run.software_version,
        "data": run.data,
    }


@dataclass(frozen=True)
class SupplyReading:
    """The supply voltage last recorded on the rig: value V, the run and when."""

    volts: float
    run_id: str
    at: datetime

    def describe(self) -> str:
        return (
            f"{self.volts:.3g} V, the supply recorded last (run {self.run_id[:8]}, "
            f"{self.at.astimezone(UTC).strftime('%Y-%m-%d %H:%M')} UTC)"
        )


def measured_supply(store: Store) -> SupplyReading | None:
    """The newest good ``supply_voltage`` sample among the last runs, or None (the rig has no
    such channel, or no run recorded it)."""
    for run in store.list_runs(limit=SUPPLY_RUNS_SEARCHED):
        if "supply_voltage" not in run.channel_names:
            continue
        sample = store.last_sample(run.id)
        if sample is None:
            continue
        volts = sample.channels.get("supply_voltage")
        if volts is not None and math.isfinite(volts) and volts > 0:
            return SupplyReading(float(volts), run.id, run.stopped_at or run.started_at)
    return None


def voltage_for(store: Store, reference_v: float, volts: float | None) -> tuple[float, str]:
    """The supply voltage to evaluate a thrust law at, and which one it is: ``volts`` when
    given, else the supply the rig recorded last, else the calibration's reference voltage."""
    if volts is not None:
        return volts, f"{volts:g} V, as given"
    supply = measured_supply(store)
    if supply is not None:
        return supply.volts, supply.describe()
    return reference_v, (
        f"{reference_v:g} V, the calibration's reference (no supply voltage recorded on the rig)"
    )
