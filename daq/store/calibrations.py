"""Thrust calibrations imported from thrust-stand tables (no run behind them)."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

import sqlalchemy as sa

from daq.store import checks
from daq.store.database import StoreBase, created_stamp, inserted_id
from daq.store.run_records import to_datetime
from daq.store.schema import thrust_calibrations

#: The largest id a calibration can have (64-bit keys).
MAX_CALIBRATION_ID = 2**63 - 1


class CalibrationNotFound(KeyError):
    """No imported calibration with that id."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else "calibration not found"


@dataclass(frozen=True)
class CalibrationInfo:
    id: int
    name: str
    created_at: datetime
    software_version: str
    data: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return {
            "id": self.id,
            "name": self.name,
            "created_at": self.created_at.isoformat(),
            "software_version": self.software_version,
            "data": self.data,
        }


class ImportedCalibrations(StoreBase):
    """The imported-calibrations part of :class:`daq.store.Store`."""

    def add_calibration(self, name: str, data: dict) -> int:
        """Store an imported calibration table; returns its id."""
        checks.check_json("data", data)
        if not name or len(name) > 200:
            raise ValueError(f"name: got {name!r}, allowed: 1 … 200 characters")
        with self.transaction() as conn:
            inserted = conn.execute(
                sa.insert(thrust_calibrations).values(name=name, data=data, **created_stamp())
            )
        return inserted_id(inserted)

    def _calibrations(self, query: sa.Select) -> list[CalibrationInfo]:
        with self.engine.connect() as conn:
            rows = conn.execute(query).all()
        return [
            CalibrationInfo(r.id, r.name, to_datetime(r.created_at), r.software_version, r.data)
            for r in rows
        ]

    def imported_calibration(self, calibration_id: int | str) -> CalibrationInfo:
        """One imported calibration; ``CalibrationNotFound`` names the id."""
        try:
            key = int(calibration_id)
        except (TypeError, ValueError):
            raise CalibrationNotFound(
                f"no imported calibration with id {calibration_id!r}"
            ) from None
        if not 0 < key <= MAX_CALIBRATION_ID:
            raise CalibrationNotFound(f"no imported calibration with id {calibration_id}")
        found = self._calibrations(
            sa.select(thrust_calibrations).where(thrust_calibrations.c.id == key)
        )
        if not found:
            raise CalibrationNotFound(f"no imported calibration with id {calibration_id}")
        return found[0]

    def imported_calibrations(self) -> list[CalibrationInfo]:
        """Every imported calibration, oldest first."""
        t = thrust_calibrations
        return self._calibrations(sa.select(t).order_by(t.c.created_at, t.c.id))

    def latest_imported_calibration(self) -> CalibrationInfo | None:
        """The newest imported calibration, or None."""
        t = thrust_calibrations
        found = self._calibrations(
            sa.select(t).order_by(t.c.created_at.desc(), t.c.id.desc()).limit(1)
        )
        return found[0] if found else None
