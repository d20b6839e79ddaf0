"""Runs from CSV files (imported or exported data), without the rig's store."""

from __future__ import annotations

import csv
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from estimation.data.csv_dialect import COMMENT, TableDialect, sniff_dialect
from estimation.data.run_arrays import RunData, validate_run, windowed_run
from estimation.data.window import check_time_step

#: Seconds per unit of the time column.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: The release coil column of each axis, and the end-of-travel switch (tows).
RELEASE_COLUMN = {"surge": "tow_release", "yaw": "spin_release"}
END_COLUMN = "end_of_travel"


def without_comments(lines: Iterable[str], *, keep_line_numbers: bool = False) -> Iterator[str]:
    """The lines for ``csv.reader`` without comment lines; with ``keep_line_numbers`` each
    comment becomes an empty line (a row ``[]``), so row numbers stay the file's lines."""
    for line in lines:
        if not line.startswith(COMMENT):
            yield line
        elif keep_line_numbers:
            yield "\n"


def run_from_csv(
    path: str | Path,
    *,
    axis: str,
    drive: float | None = None,
    time_column: str = "t",
    position_column: str = "position",
    drive_column: str = "drive",
    run_id: str | None = None,
    time_unit: str = "s",
    **metadata: Any,
) -> RunData:
    """Read one run from a CSV with a header row: time (``time_unit``), position (m or rad),
    optional per-sample drive (N or N·m). ``drive`` (a constant) overrides the column; other
    ``RunData`` fields (hung_mass_kg, drive_inertia, drum_radius_m, t_release, t_end) pass
    through. Without ``t_release``/``t_end`` the window is found in the recording
    (``estimation.data.window``: the ``tow_release``/``spin_release`` and ``end_of_travel``
    columns when present, else the motion); isolated encoder spikes are dropped either way.
    Raises ValueError naming the missing column or bad value.
    """
    path = Path(path)
    if time_unit not in TIME_UNITS:
        raise ValueError(f"time_unit: got {time_unit!r}, allowed: {', '.join(TIME_UNITS)}")
    with path.open(newline="", encoding="utf-8-sig") as f:  # Excel's BOM dropped
        dialect = sniff_dialect(f)
        f.seek(0)
        reader = csv.DictReader(without_comments(f), delimiter=dialect.delimiter)
        header = list(reader.fieldnames or [])
        wanted = [time_column, position_column] + ([] if drive is not None else [drive_column])
        missing = [c for c in wanted if c not in header]
        if missing:
            raise ValueError(f"{path.name}: columns: got {header}, missing {missing}")
        rows = list(reader)
    number = dialect.number
    try:
        t = np.array([number(r[time_column]) for r in rows]) * TIME_UNITS[time_unit]
        x = np.array([number(r[position_column]) for r in rows])
        d: float | np.ndarray = (
            float(drive) if drive is not None else np.array([number(r[drive_column]) for r in rows])
        )
        coil, switch = (
            _column(rows, header, name, dialect)
            for name in (RELEASE_COLUMN.get(axis, ""), END_COLUMN)
        )
    except ValueError as exc:
        raise ValueError(f"{path.name}: a value is not a number ({exc})") from None
    check_time_step(t, time_column, path.name)
    if isinstance(d, np.ndarray) and d.size and np.ptp(d) == 0:
        d = float(d[0])  # a constant column is a weight-driven run: use the closed form
    release_known, end_known = "t_release" in metadata, "t_end" in metadata
    run = RunData(run_id=run_id or path.stem, axis=axis, t=t, position=x, drive=d, **metadata)  # type: ignore[arg-type]
    validate_run(run)
    run = windowed_run(
        run,
        release_coil=coil,
        end_switch=switch if axis == "surge" else None,
        release_known=release_known,
        end_known=end_known,
    )
    validate_run(run)
    return run


def _column(
    rows: list[dict], header: list[str], name: str, dialect: TableDialect
) -> np.ndarray | None:
    """A numeric column when present and complete (None otherwise)."""
    if name not in header:
        return None
    values = [r[name].strip() for r in rows]
    if any(v == "" for v in values):
        return None
    return np.array([dialect.number(v) for v in values])
