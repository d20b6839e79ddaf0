"""CSV/JSON export of a stored run and CSV import of runs recorded elsewhere.

An exported CSV has columns ``t`` (s since the first sample), ``seq``, ``t_mono``,
``t_wall``, ``quality`` and one column per channel (SI; empty = not read). An imported
CSV needs a header with ``t`` (s, strictly increasing) and ``position`` (m for a tow,
rad for a spin; ``tow_position``/``yaw_angle`` are accepted too); ``seq``, ``t_mono``,
``t_wall`` and ``quality`` are used when present and every other column becomes a channel
(``tow_release``/``spin_release``/``end_of_travel`` among them tell estimation the release
and the end of travel, as an export writes them).
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from daq.sample import Quality, Sample
from daq.store.store import Store
from daq.vocabulary import AXES, DRIVEN_KINDS
from estimation.csv_import import TIME_UNITS
from estimation.window import check_time_step

#: Column the import maps ``position`` to, per run kind.
POSITION_CHANNEL = {kind: AXES[kind].position_channel for kind in DRIVEN_KINDS}
#: Parameter each imported run kind needs (the applied load).
LOAD_PARAMETER = {kind: AXES[kind].drive_key for kind in DRIVEN_KINDS}
_RESERVED = ("t", "seq", "t_mono", "t_wall", "quality")
#: Most data rows one import may hold (10⁶ rows = 28 h at 10 Hz).
MAX_IMPORT_ROWS = 1_000_000
#: Samples per transaction of a long import (SQLite's write lock is held this long).
IMPORT_BATCH_ROWS = 50_000


class CsvImportError(ValueError):
    """The CSV cannot be imported; the message names the line and column."""


def _cell(value: float) -> str:
    return "" if math.isnan(value) else repr(float(value))


def export_run_csv(store: Store, run_id: str, fileobj: TextIO) -> int:
    """Write the run's samples as CSV to ``fileobj``; returns the number of rows."""
    run = store.get_run(run_id)
    table = store.samples(run.id)
    writer = csv.writer(fileobj, lineterminator="\n")
    writer.writerow([*_RESERVED, *run.channel_names])
    t = table.t
    columns = [table.channels[name] for name in run.channel_names]
    for i in range(len(table)):
        writer.writerow(
            [
                repr(float(t[i])),
                int(table.seq[i]),
                repr(float(table.t_mono[i])),
                repr(float(table.t_wall[i])),
                int(table.quality[i]),
                *(_cell(column[i]) for column in columns),
            ]
        )
    return len(table)


def export_run_json(store: Store, run_id: str, fileobj: TextIO) -> None:
    """Write the run (metadata, samples, events, results) as one JSON document."""
    run = store.get_run(run_id)
    document = {
        "run": run.to_json(),
        "samples": store.samples(run.id).to_json(),
        "events": [e.to_json() for e in store.events(run.id)],
        "results": [r.to_json() for r in store.results(run.id)],
    }
    json.dump(document, fileobj, allow_nan=False, indent=1)
    fileobj.write("\n")


def check_import_parameters(kind: str, parameters: dict[str, Any]) -> dict[str, Any]:
    """The imported run's parameters: the load (``force_n`` or ``torque_nm``, > 0) and an
    optional ``hung_mass_kg`` (> 0), plus ``source: import``."""
    if kind not in LOAD_PARAMETER:
        raise ValueError(f"kind: {kind!r} is not allowed; use one of {', '.join(LOAD_PARAMETER)}")
    needed = LOAD_PARAMETER[kind]
    out: dict[str, Any] = {"source": "import"}
    for key, value in parameters.items():
        if key in (needed, "hung_mass_kg"):
            if value is None and key == "hung_mass_kg":
                continue
            ok = isinstance(value, int | float) and not isinstance(value, bool)
            if not ok or not math.isfinite(value) or value <= 0:
                raise ValueError(f"{key}: {value!r} is not allowed; use a finite number > 0")
            out[key] = float(value)
        else:
            out[key] = value
    if needed not in out:
        raise ValueError(f"{needed}: missing; a {kind} run needs the applied load")
    out["source"] = "import"
    return out


def _number(text: str, line: int, column: str, *, allow_missing: bool) -> float:
    stripped = text.strip()
    if allow_missing and stripped.lower() in ("", "nan"):
        return math.nan
    try:
        value = float(stripped)
    except ValueError:
        raise CsvImportError(f"line {line}, column {column!r}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise CsvImportError(
            f"line {line}, column {column!r}: {text!r} is not allowed; use a finite number"
        )
    return value


def _header(row: list[str], kind: str, path: Path) -> tuple[list[str], list[str]]:
    columns = [c.strip() for c in row]
    if not columns or "t" not in columns:
        raise CsvImportError(
            f"{path}: line 1: no header with a 't' column (got {row!r}); expected e.g. 't,position'"
        )
    dupes = sorted({c for c in columns if columns.count(c) > 1})
    if dupes or "" in columns:
        raise CsvImportError(f"{path}: line 1: empty or repeated column names {dupes or ['']}")
    target = POSITION_CHANNEL[kind]
    if "position" in columns and target in columns:
        raise CsvImportError(f"{path}: line 1: both 'position' and {target!r}; keep one")
    if "position" not in columns and target not in columns:
        raise CsvImportError(
            f"{path}: line 1: no 'position' column (m for tow, rad for spin) in {columns}"
        )
    channels = [target if c == "position" else c for c in columns if c not in _RESERVED]
    renamed = [target if c == "position" else c for c in columns]
    return renamed, channels


def _read_samples(
    path: Path, kind: str, time_scale: float = 1.0
) -> tuple[list[str], list[Sample], bool, list[float]]:
    with open(path, newline="", encoding="utf-8") as f:
        try:
            return _parse_rows(path, kind, csv.reader(f), time_scale)
        except UnicodeDecodeError as err:
            raise CsvImportError(
                f"{path}: not UTF-8 text ({err.reason} at byte {err.start})"
            ) from None


def _parse_rows(
    path: Path, kind: str, reader: Iterator[list[str]], time_scale: float
) -> tuple[list[str], list[Sample], bool, list[float]]:
    rows = ((n, r) for n, r in enumerate(reader, start=1) if r and any(r))
    first = next(rows, None)
    if first is None:
        raise CsvImportError(f"{path}: empty file; expected a header row 't,position'")
    header_line, header_row = first
    columns, channels = _header(header_row, kind, path)
    position = POSITION_CHANNEL[kind]
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
            missing_ok = column not in ("t", position, "seq", "t_mono", "t_wall", "quality")
            values[column] = _number(text, line, column, allow_missing=missing_ok)
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
        previous = values
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
    if not samples:
        raise CsvImportError(f"{path}: line {header_line}: a header but no data rows")
    try:
        check_time_step(np.asarray(times), "t", str(path))
    except ValueError as err:
        raise CsvImportError(str(err)) from None
    return channels, samples, "t_wall" in columns, times


def _window_times(
    times: list[float], samples: list[Sample], given: dict[str, float | None]
) -> dict[str, float]:
    """The given release/end instants (s, on the CSV's ``t`` axis) as seconds since the
    stored run's first sample (its ``t_mono`` axis), checked against the recording."""
    out: dict[str, float] = {}
    lo, hi = times[0], times[-1]
    for key, value in given.items():
        if value is None:
            continue
        if not math.isfinite(value) or not lo <= value <= hi:
            raise CsvImportError(
                f"{key}: {value!r} is not allowed; use a time within the file's t range "
                f"[{lo:g}, {hi:g}] s"
            )
        mono = [s.t_mono for s in samples]
        out[key] = float(np.interp(value, times, mono)) - mono[0]
    if len(out) == 2 and not out["release_time_s"] < out["end_time_s"]:
        raise CsvImportError(
            f"end_time_s: {given['end_time_s']!r} is not allowed; use a time after "
            f"release_time_s ({given['release_time_s']!r})"
        )
    return out


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
) -> str:
    """Import a CSV as a completed ``kind`` (``tow``/``spin``) run; returns the new run id.
    Nothing is written when the file or parameters are bad (all is parsed first). Up to
    ``IMPORT_BATCH_ROWS`` samples go in one transaction; a longer run in transactions of
    that many, so a live run sharing the database is never locked out for long.

    ``time_unit`` (s, ms, us) is the unit of the ``t`` column; a median step over 1 s is
    refused as evidently not seconds. ``release_time_s``/``end_time_s`` (on the CSV's ``t``
    axis, in s) are stored as parameters (seconds since the first sample) that estimation
    takes for the release and the end of free motion instead of finding them."""
    path = Path(path)
    if time_unit not in TIME_UNITS:
        raise ValueError(
            f"time_unit: {time_unit!r} is not allowed; use one of {', '.join(TIME_UNITS)}"
        )
    params = check_import_parameters(kind, parameters)
    params.setdefault("file", path.name)
    channels, samples, has_wall, times = _read_samples(path, kind, TIME_UNITS[time_unit])
    params.update(
        _window_times(times, samples, {"release_time_s": release_time_s, "end_time_s": end_time_s})
    )
    if not has_wall:
        t0 = samples[0].t_wall
        start = time.time()
        samples = [
            Sample(s.seq, s.t_mono, start + (s.t_wall - t0), s.channels, s.quality) for s in samples
        ]
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
    )
