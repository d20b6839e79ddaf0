"""CSV import of runs recorded elsewhere into the store.

An imported CSV may open with ``#`` comment lines (an export's, ``daq.store.csv_export``:
they are skipped) and needs a header with ``t`` (s, strictly increasing) and ``position``
(m for a tow, rad for a spin; ``tow_position``/``yaw_angle`` are accepted too); ``seq``,
``t_mono``, ``t_wall`` and ``quality`` are used when present and every other column becomes
a channel (``tow_release``/``spin_release``/``end_of_travel`` among them tell estimation the
release and the end of travel, as an export writes them).
A pendulum free decay has ``position`` (or ``pendulum_angle``) in rad. A drive logged
per sample (a force column of a tow, a torque column of a spin, in a unit of
``LOGGED_DRIVE_UNITS``) is stored in SI as the ``drive_force``/``drive_torque`` channel,
which estimation takes as the drive instead of a constant ``force_n``/``torque_nm``.

An import takes the ``# metadata: {…}`` line (the run's metadata, JSON) back as the new
run's metadata.

The file is read with estimation's CSV rules (``estimation.data.csv_dialect``: separator,
decimal comma, Excel's byte-order mark), so this module lives outside ``daq.store``, which
imports nothing of ``estimation``.
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from daq.sample import Quality, Sample
from daq.store import Store
from daq.store.import_checks import check_drive_direction, check_logged_peak, window_times
from daq.store.run_metadata import check_run_metadata
from daq.vocabulary import AXES, DRIVE_FIELD, LOGGED_DRIVE_CHANNEL
from estimation.data.csv_dialect import COMMA, TableDialect, sniff_dialect
from estimation.data.csv_import import TIME_UNITS, without_comments
from estimation.data.window import check_time_step

_RESERVED = ("t", "seq", "t_mono", "t_wall", "quality")
#: Most data rows one import may hold (10⁶ rows = 28 h at 10 Hz).
MAX_IMPORT_ROWS = 1_000_000
#: Samples per transaction of a long import (SQLite's write lock is held this long).
IMPORT_BATCH_ROWS = 50_000


#: Units a logged drive column may be in, per driven kind, with their scale to its drive's SI
#: unit: a force unit to N (a tow), or a force unit times the lever's metre to N·m (a spin).
_FORCE_UNITS = {"N": 1.0, "kN": 1000.0, "kgf": 9.80665, "gf": 9.80665e-3, "lbf": 4.4482216152605}
LOGGED_DRIVE_UNITS: dict[str, dict[str, float]] = {
    kind: {f"{unit}{lever}": scale for unit, scale in _FORCE_UNITS.items()}
    for kind, (_, si) in DRIVE_FIELD.items()
    for lever in (si.removeprefix("N"),)  # "" for N, "·m" for N·m
}
#: The kinds a CSV can be imported as.
IMPORT_KINDS = tuple(AXES)  # every kind with a position channel


class CsvImportError(ValueError):
    """The CSV cannot be imported; the message names the line and column."""


def logged_drive_scale(kind: str, unit: str) -> float:
    """SI per unit of a logged drive column (``N*m`` is read as ``N·m``); ``ValueError``
    naming ``drive_unit`` and the allowed units."""
    units = LOGGED_DRIVE_UNITS.get(kind)
    if units is None:
        raise ValueError(f"drive_column: a {kind} run has no drive; allowed for tow or spin")
    scale = units.get(unit.strip().replace("*", "·").replace(".", "·"))
    if scale is None:
        raise ValueError(f"drive_unit: {unit!r} is not allowed; use one of {', '.join(units)}")
    return scale


def check_import_parameters(
    kind: str, parameters: dict[str, Any], *, logged_drive: bool = False
) -> dict[str, Any]:
    """The imported run's parameters: the load (``force_n`` or ``torque_nm``, signed and not
    0: negative is a reverse run; none with a ``logged_drive`` column, nor for a pendulum)
    and an optional ``hung_mass_kg`` (> 0), plus ``source: import``."""
    if kind not in IMPORT_KINDS:
        raise ValueError(
            f"kind: {kind!r} is not allowed; use one of {', '.join(map(str, IMPORT_KINDS))}"
        )
    if kind not in DRIVE_FIELD:
        return {**parameters, "source": "import"}
    needed = DRIVE_FIELD[kind][0]
    if logged_drive and parameters.get(needed) is not None:
        raise ValueError(f"{needed}: not used with drive_column (the drive is logged per sample)")
    out: dict[str, Any] = {"source": "import"}
    for key, value in parameters.items():
        if key in (needed, "hung_mass_kg"):
            if value is None and key == "hung_mass_kg":
                continue
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if key == needed:  # signed: a negative load is a reverse run
                if not ok or not math.isfinite(value) or value == 0:
                    raise ValueError(
                        f"{key}: {value!r} is not allowed; use a finite number other than 0 "
                        "(negative: a reverse run)"
                    )
            elif not ok or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{key}: {value!r} is not allowed; use a finite number > 0")
            out[key] = float(value)
        else:
            out[key] = value
    if needed not in out and not logged_drive:
        raise ValueError(
            f"{needed}: missing; a {kind} run needs the applied load (or a drive_column)"
        )
    out["source"] = "import"
    return out


def _number(
    text: str, line: int, column: str, *, allow_missing: bool, dialect: TableDialect
) -> float:
    stripped = text.strip()
    if allow_missing and stripped.lower() in ("", "nan"):
        return math.nan
    try:
        value = dialect.number(stripped)
    except ValueError:
        raise CsvImportError(f"line {line}, column {column!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise CsvImportError(
            f"line {line}, column {column!r}: {text!r} is not allowed; use a finite number"
        )
    return value


def _header(
    row: list[str], kind: str, path: Path, drive_column: str | None = None
) -> tuple[list[str], list[str]]:
    columns = [c.strip() for c in row]
    if not columns or "t" not in columns:
        raise CsvImportError(
            f"{path}: line 1: no header with a 't' column (got {row!r}); expected e.g. 't,position'"
        )
    dupes = sorted({c for c in columns if columns.count(c) > 1})
    if dupes or "" in columns:
        raise CsvImportError(f"{path}: line 1: empty or repeated column names {dupes or ['']}")
    target = AXES[kind].position_channel
    if "position" in columns and target in columns:
        raise CsvImportError(f"{path}: line 1: both 'position' and {target!r}; keep one")
    if "position" not in columns and target not in columns:
        raise CsvImportError(
            f"{path}: line 1: no 'position' column (m for tow, rad for spin and pendulum) "
            f"in {columns}"
        )
    names = {"position": target}
    if drive_column is not None:
        logged = LOGGED_DRIVE_CHANNEL[kind]
        if drive_column not in columns:
            raise CsvImportError(f"drive_column: no column {drive_column!r} in {path}: {columns}")
        if drive_column in _RESERVED or drive_column in ("position", target):
            raise CsvImportError(f"drive_column: {drive_column!r} is not a drive column")
        if logged in columns and drive_column != logged:
            raise CsvImportError(
                f"drive_column: {path} has a {logged!r} column too; name that one or drop it"
            )
        names[drive_column] = logged
    renamed = [names.get(c, c) for c in columns]
    channels = [c for c in renamed if c not in _RESERVED]
    return renamed, channels


def _comment_metadata(path: Path, line: int, text: str) -> dict[str, Any] | None:
    """The metadata of a ``# metadata: {…}`` line (None for any other comment)."""
    body = text.lstrip("#").strip()
    if not body.startswith("metadata:"):
        return None
    try:
        value = json.loads(body.removeprefix("metadata:"))
    except json.JSONDecodeError as err:
        message = f"{path}: line {line}: '# metadata:' is not JSON ({err.msg})"
        raise CsvImportError(message) from None
    return value if isinstance(value, dict) else None


def read_csv_metadata(path: str | Path) -> dict[str, Any]:
    """The ``# metadata:`` comment of a CSV's leading comment lines ({} when none)."""
    path = Path(path)
    found: dict[str, Any] = {}
    with open(path, encoding="utf-8", errors="replace") as f:
        for line, text in enumerate(f, start=1):
            if not text.startswith("#"):
                break
            found = _comment_metadata(path, line, text) or found
    return found


def _read_samples(
    path: Path,
    kind: str,
    time_scale: float = 1.0,
    drive: tuple[str, float] | None = None,
) -> tuple[list[str], list[Sample], bool, list[float]]:
    """``drive``: the logged drive column and its SI scale (None: no such column)."""
    with open(path, newline="", encoding="utf-8-sig") as f:  # Excel's BOM dropped
        try:
            dialect = sniff_dialect(f)
            f.seek(0)
            lines = without_comments(f, keep_line_numbers=True)
            rows = csv.reader(lines, delimiter=dialect.delimiter)
            return _parse_rows(path, kind, rows, time_scale, drive, dialect)
        except UnicodeDecodeError as err:
            raise CsvImportError(
                f"{path}: not UTF-8 text ({err.reason} at byte {err.start})"
            ) from None


def _parse_rows(
    path: Path,
    kind: str,
    reader: Iterator[list[str]],
    time_scale: float,
    drive: tuple[str, float] | None = None,
    dialect: TableDialect = COMMA,
) -> tuple[list[str], list[Sample], bool, list[float]]:
    rows = ((n, r) for n, r in enumerate(reader, start=1) if r and any(r))
    first = next(rows, None)
    if first is None:
        raise CsvImportError(f"{path}: empty file; expected a header row 't,position'")
    header_line, header_row = first
    columns, channels = _header(header_row, kind, path, drive[0] if drive else None)
    position = AXES[kind].position_channel
    logged, scale = (LOGGED_DRIVE_CHANNEL[kind], drive[1]) if drive else ("", 1.0)
    names = {logged: drive[0]} if drive else {}  # errors name the file's drive column
    samples: list[Sample] = []
    times: list[float] = []
    previous: dict[str, float] = {}
    for line, row in rows:
        if len(samples) >= MAX_IMPORT_ROWS:
            raise CsvImportError(
                f"{path}: line {line}: more than {MAX_IMPORT_ROWS} data rows (the import limit)"
            )
        if len(row) != len(columns):
            raise CsvImportError(
                f"{path}: line {line}: {len(row)} fields, the header has {len(columns)}"
            )
        values: dict[str, float] = {}
        for column, text in zip(columns, row, strict=True):
            missing_ok = column not in ("t", logged, "seq", "t_mono", "t_wall", "quality")
            values[column] = _number(
                text, line, names.get(column, column), allow_missing=missing_ok, dialect=dialect
            )
            rising = column in ("t", "seq", "t_mono") and column in previous
            if rising and values[column] <= previous[column]:
                raise CsvImportError(
                    f"{path}: line {line}, column {column!r}: {text.strip()!r} is not "
                    f"greater than the previous {previous[column]!r} (must strictly increase)"
                )
        for column in ("seq", "quality"):
            if column in values and (values[column] != int(values[column]) or values[column] < 0):
                raise CsvImportError(
                    f"{path}: line {line}, column {column!r}: {values[column]!r} is not "
                    "allowed; use an integer ≥ 0"
                )
        # a towrig export writes a failed read's position empty, its own quality flagging it:
        # imported as recorded (NaN, flagged) for estimation to leave out; refused elsewhere
        unread = int(values.get("quality", 0)) & Quality.ERROR
        if math.isnan(values[position]) and not unread:
            text = row[columns.index(position)]
            raise CsvImportError(
                f"line {line}, column {names.get(position, position)!r}: {text!r} is not a number"
            )
        previous = values
        if logged:
            values[logged] *= scale
        t = values["t"] * time_scale
        times.append(t)
        samples.append(
            Sample(
                seq=int(values.get("seq", len(samples))),
                t_mono=values.get("t_mono", t),
                t_wall=values.get("t_wall", t),  # shifted below if absent
                channels={name: values[name] for name in channels},
                quality=Quality(int(values.get("quality", 0))),
            )
        )
    if len(samples) < 2:
        raise CsvImportError(
            f"{path}: line {header_line}: a header but {len(samples) or 'no'} data "
            f"row{'s' if not samples else ''}; a run needs at least 2 samples (one time step)"
        )
    try:
        check_time_step(np.asarray(times), "t", str(path))
    except ValueError as err:
        raise CsvImportError(str(err)) from None
    return channels, samples, "t_wall" in columns, times


def import_csv(
    store: Store,
    path: str | Path,
    *,
    kind: str,
    parameters: dict[str, Any],
    rig_name: str = "imported",
    vehicle: str = "unknown",
    rig_toml: str = "",
    time_unit: str = "s",
    release_time_s: float | None = None,
    end_time_s: float | None = None,
    metadata: dict[str, Any] | None = None,
    drive_column: str | None = None,
    drive_unit: str | None = None,
    drive_limit: tuple[str, float] | None = None,
) -> str:
    """Import a CSV as a completed ``kind`` (``tow``/``spin``/``pendulum``) run; returns
    the new run id.
    The run is marked imported from the file's name (now), keeps the recorded start time
    and takes the file's ``# metadata:`` comment updated by ``metadata``.
    Nothing is written when the file or parameters are bad (all is parsed first). Up to
    ``IMPORT_BATCH_ROWS`` samples go in one transaction; a longer run in transactions of
    that many, so a live run sharing the database is never locked out for long.

    ``time_unit`` (s, ms, us) is the unit of the ``t`` column; a median step over 1 s is
    refused as evidently not seconds. ``release_time_s``/``end_time_s`` (on the CSV's ``t``
    axis, in s) are stored as parameters (seconds since the first sample) that estimation
    takes for the release and the end of free motion instead of finding them; a tow's or
    spin's release may come before the first sample (negative: the record starts after it).

    ``drive_column`` (tow/spin): the column holding the drive logged per sample, in
    ``drive_unit`` (default N or N·m); stored in SI as ``LOGGED_DRIVE_CHANNEL[kind]``
    and named by the run's ``drive_channel`` parameter (no ``force_n``/``torque_nm``).
    A pendulum run needs ``rig_toml`` with a ``[pendulum]`` section to be estimated.

    The samples are checked against the parameters (``daq.store.import_checks``): a
    constant drive whose sign disagrees with the record's first motion is refused, and a
    logged drive over ``drive_limit`` (the rig limit's name and value, SI)."""
    path = Path(path)
    if time_unit not in TIME_UNITS:
        raise ValueError(
            f"time_unit: {time_unit!r} is not allowed; use one of {', '.join(TIME_UNITS)}"
        )
    params = check_import_parameters(kind, parameters, logged_drive=drive_column is not None)
    params.setdefault("file", path.name)
    drive = None
    if drive_column is not None:
        unit = drive_unit or DRIVE_FIELD.get(kind, ("", ""))[1]
        drive = (drive_column.strip(), logged_drive_scale(kind, unit))
        params |= {
            "drive_channel": LOGGED_DRIVE_CHANNEL[kind],
            "drive_column": drive_column.strip(),
            "drive_unit": unit,
        }
    elif drive_unit is not None:
        raise ValueError("drive_unit: only with drive_column")
    channels, samples, has_wall, times = _read_samples(path, kind, TIME_UNITS[time_unit], drive)
    position = [s.channels[AXES[kind].position_channel] for s in samples]
    check_drive_direction(kind, params, np.asarray(position))
    if drive is not None:
        logged = [s.channels[LOGGED_DRIVE_CHANNEL[kind]] for s in samples]
        check_logged_peak(kind, drive[0], logged, drive_limit)
    params.update(
        window_times(
            times,
            samples,
            {"release_time_s": release_time_s, "end_time_s": end_time_s},
            early=kind in DRIVE_FIELD,
        )
    )
    if not has_wall:
        t0 = samples[0].t_wall
        start = time.time()
        samples = [
            Sample(s.seq, s.t_mono, start + (s.t_wall - t0), s.channels, s.quality) for s in samples
        ]
    carried = check_run_metadata(read_csv_metadata(path), prefix=f"{path.name}: metadata.")
    carried.update(check_run_metadata(metadata))
    return store.import_run(
        kind=kind,
        parameters=params,
        channel_names=channels,
        rig_name=rig_name,
        vehicle=vehicle,
        rig_toml=rig_toml,
        samples=samples,
        started_at=samples[0].t_wall,
        stopped_at=samples[-1].t_wall,
        batch_rows=IMPORT_BATCH_ROWS,
        source_file=Path(str(params["file"])).name or path.name,
        metadata=carried,
    )
