"""CSV/JSON export of a stored run.

An exported CSV opens with ``#`` comment lines (the run's description, ``# metadata: {…}``
and ``# units: t=s, …, tow_position=m``), then has columns ``t`` (s since the first sample),
``seq``, ``t_mono``, ``t_wall``, ``quality`` and one column per channel (SI; empty = not
read), each number at its channel's resolution. ``daq.csv_to_store`` reads such a file back
as the same run.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Iterator
from typing import TextIO

from daq.store.channel_units import at_resolution, column_infos, table_at_resolution, units_line
from daq.store.export_header import EXPORT_MARK
from daq.store.run_attributes import MULTILINE, release_time, run_attributes
from daq.store.run_records import EventInfo, RunInfo
from daq.store.store import Store

#: A line of an export starting with this is a comment (``estimation.data.csv_dialect``
#: skips them on reading).
COMMENT = "#"
#: Samples per page of a CSV export (bounded memory for long runs).
CSV_PAGE_ROWS = 5000


def _text(value: float, decimals: int | None) -> str:
    if math.isnan(value):
        return ""
    return str(int(value)) if decimals == 0 else repr(float(value))


def csv_header(run: RunInfo, events: list[EventInfo], first_t_mono: float) -> list[str]:
    """The comment lines that open an export: the run's attributes (one ``# key: value``
    each; the rig file's text left out) and ``# units: t=s, …``."""
    release_t = release_time(run, events, first_t_mono)
    attrs = run_attributes(run, events, release_t=release_t)
    lines = [f"{COMMENT} {EXPORT_MARK}: these comments, a header row, a row per sample"]
    for key, value in attrs.items():
        if key in MULTILINE:
            continue
        text = value if isinstance(value, str) else repr(value)
        if any(c in text for c in "\r\n"):
            text = json.dumps(text, ensure_ascii=False)
        lines.append(f"{COMMENT} {key}: {text}")
    lines.append(f"{COMMENT} metadata: {json.dumps(run.metadata, ensure_ascii=False)}")
    lines.append(f"{COMMENT} units: {units_line(column_infos(run))}")
    return lines


def csv_chunks(store: Store, run_id: str, page_rows: int = CSV_PAGE_ROWS) -> Iterator[str]:
    """The run as CSV text, a page of samples at a time (bounded memory for long runs):
    header comments (run description, ``# units: …``), the column names, then one row
    per sample with each number at its channel's resolution (``channel_units``)."""
    for text, _rows in _csv_pages(store, run_id, page_rows):
        yield text


def _csv_pages(store: Store, run_id: str, page_rows: int) -> Iterator[tuple[str, int]]:
    run = store.get_run(run_id)
    infos = column_infos(run)
    columns = list(infos)
    names = run.channel_names
    first = store.samples(run.id, limit=1).t_mono[:1]
    first_t_mono = float(first[0]) if first.size else 0.0
    t0 = float(at_resolution(first, infos["t_mono"])[0]) if first.size else 0.0
    buf = io.StringIO()
    for line in csv_header(run, store.events(run.id), first_t_mono):
        buf.write(line + "\n")
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    start = 0
    while True:
        table = table_at_resolution(store.samples(run.id, start_seq=start, limit=page_rows), infos)
        t = at_resolution(table.t_mono - t0, infos["t"])
        cells = [t, table.seq, table.t_mono, table.t_wall, table.quality]
        cells += [table.channels[name] for name in names]
        decimals = [infos[name].decimals for name in columns]
        for row in zip(*(c.tolist() for c in cells), strict=True):
            writer.writerow([_text(v, d) for v, d in zip(row, decimals, strict=True)])
        yield buf.getvalue(), len(table)
        buf.seek(0)
        buf.truncate()
        if len(table) < page_rows:
            return
        start = int(table.seq[-1]) + 1


def export_run_csv(store: Store, run_id: str, fileobj: TextIO) -> int:
    """Write the run as CSV to ``fileobj`` (see :func:`csv_chunks`); returns the number
    of sample rows."""
    rows = 0
    for text, count in _csv_pages(store, run_id, CSV_PAGE_ROWS):
        fileobj.write(text)
        rows += count
    return rows


def export_run_json(store: Store, run_id: str, fileobj: TextIO) -> None:
    """Write the run (metadata, samples, events, results) as one JSON document; numbers
    at their channel's resolution, each channel's unit in ``units``."""
    run = store.get_run(run_id)
    infos = column_infos(run)
    document = {
        "run": run.to_json(),
        "units": {name: info.units for name, info in infos.items()},
        "samples": table_at_resolution(store.samples(run.id), infos).to_json(),
        "events": [e.to_json() for e in store.events(run.id)],
        "results": [r.to_json() for r in store.results(run.id)],
    }
    json.dump(document, fileobj, allow_nan=False, indent=1)
    fileobj.write("\n")
