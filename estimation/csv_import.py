"""Runs from CSV files (imported or exported data), without the rig's store."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import numpy as np

from estimation.runs import RunData, validate_run


def run_from_csv(
    path: str | Path,
    *,
    axis: str,
    drive: float | None = None,
    time_column: str = "t",
    position_column: str = "position",
    drive_column: str = "drive",
    run_id: str | None = None,
    **metadata: Any,
) -> RunData:
    """Read one run from a CSV with a header row: time (s), position (m or rad), optional
    per-sample drive (N or N·m). ``drive`` (a constant) overrides the column; other
    ``RunData`` fields (hung_mass_kg, drive_inertia, drum_radius_m, t_release, t_end) pass
    through. Raises ValueError naming the missing column or bad value.
    """
    path = Path(path)
    with path.open(newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        header = reader.fieldnames or []
        wanted = [time_column, position_column] + ([] if drive is not None else [drive_column])
        missing = [c for c in wanted if c not in header]
        if missing:
            raise ValueError(f"{path.name}: columns: got {header}, missing {missing}")
        rows = list(reader)
    try:
        t = np.array([float(r[time_column]) for r in rows])
        x = np.array([float(r[position_column]) for r in rows])
        d = float(drive) if drive is not None else np.array([float(r[drive_column]) for r in rows])
    except ValueError as exc:
        raise ValueError(f"{path.name}: a value is not a number ({exc})") from None
    if drive is None and np.ptp(d) == 0 and d.size:
        d = float(d[0])  # a constant column is a weight-driven run: use the closed form
    run = RunData(run_id=run_id or path.stem, axis=axis, t=t, position=x, drive=d, **metadata)  # type: ignore[arg-type]
    validate_run(run)
    return run
