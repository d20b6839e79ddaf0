"""The formats a run can be exported in: one table (``FORMATS``) from which the CLI's
``--format`` choices and help, the HTTP route's query type, its OpenAPI enum and docs, and
the browser's export menu (``GET /api/export-formats``) are all derived. A new format is
one entry here plus its writer.

Light to import (the CLI lists the formats in its help without loading the store): every
writer imports what it needs (pandas, xarray, pyarrow, scipy) when it is called.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Literal

if TYPE_CHECKING:
    from daq.store.store import Store

#: A writer: ``(store, run_id, path)`` writes the run's file at ``path``.
Writer = Callable[["Store", str, Path], object]


@dataclass(frozen=True)
class FormatInfo:
    """An export format as ``GET /api/export-formats`` lists it: its ``name``
    (``--format``/``?format=``), the ``suffix`` of its files, its ``media_type``, the
    ``label`` of the browser's menu entry, a one-line ``help``, and whether it is ``binary``
    (not for a terminal)."""

    name: str
    suffix: str
    media_type: str
    label: str
    help: str
    binary: bool


@dataclass(frozen=True)
class ExportFormat(FormatInfo):
    """One export format: what the list shows (:class:`FormatInfo`) and its ``writer``."""

    writer: Writer

    def public(self) -> dict[str, str | bool]:
        """The entry as ``GET /api/export-formats`` lists it: the fields of :class:`FormatInfo`
        (all but the writer)."""
        return {f.name: getattr(self, f.name) for f in fields(FormatInfo)}


def _write_csv(store: Store, run_id: str, path: Path) -> None:
    from daq.store.csv_export import export_run_csv

    with open(path, "w", encoding="utf-8", newline="") as f:
        export_run_csv(store, run_id, f)


def _write_json(store: Store, run_id: str, path: Path) -> None:
    from daq.store.csv_export import export_run_json

    with open(path, "w", encoding="utf-8", newline="") as f:
        export_run_json(store, run_id, f)


def _write_netcdf(store: Store, run_id: str, path: Path) -> None:
    store.load(run_id).to_netcdf(path)  # xarray and h5netcdf are imported by the writer


def _write_parquet(store: Store, run_id: str, path: Path) -> None:
    store.load(run_id).to_parquet(path)  # pandas and pyarrow are imported by the writer


def _write_mat(store: Store, run_id: str, path: Path) -> None:
    from daq.store.mat_export import write_mat

    write_mat(store.load(run_id), path)


FORMATS: dict[str, ExportFormat] = {
    f.name: f
    for f in (
        ExportFormat(
            "csv", ".csv", "text/csv", "CSV (units in # comments)",
            "comment lines (run description, units), then a row per sample", False, _write_csv,
        ),
        ExportFormat(
            "json", ".json", "application/json", "JSON",
            "one document: run, units, samples, events, results", False, _write_json,
        ),
        ExportFormat(
            "netcdf", ".nc", "application/x-netcdf", "NetCDF (xarray)",
            "NetCDF-4 for xarray: units per variable, the run as global attributes", True,
            _write_netcdf,
        ),
        ExportFormat(
            "parquet", ".parquet", "application/vnd.apache.parquet", "Parquet (pandas)",
            "Parquet for pandas/arrow: units in the schema, the run in df.attrs", True,
            _write_parquet,
        ),
        ExportFormat(
            "mat", ".mat", "application/x-matlab-data", "MATLAB (.mat)",
            "MATLAB v5 for load(): columns in struct data, units in units, the run in metadata",
            True, _write_mat,
        ),
    )
}  # fmt: skip

if TYPE_CHECKING:
    FormatName = str
else:  # Literal["csv", "json", …] built from the table: the HTTP query type and its enum
    FormatName = Literal[tuple(FORMATS)]


def formats_help() -> str:
    """``name: help`` of every format, ``; ``-separated (the CLI's and the route's help)."""
    return "; ".join(f"{f.name}: {f.help}" for f in FORMATS.values())


def export_file_name(run_id: str, fmt: str) -> str:
    """``run-<first 8 of the id><suffix>``."""
    return f"run-{run_id[:8]}{FORMATS[fmt].suffix}"


def write_export(store: Store, run_id: str, fmt: str, path: str | Path) -> Path:
    """Write the run in format ``fmt`` (a key of ``FORMATS``) to ``path``."""
    if fmt not in FORMATS:
        raise ValueError(f"format: {fmt!r} is not allowed; use one of {', '.join(FORMATS)}")
    path = Path(path)
    with open(path, "wb"):  # a path that cannot be written fails here, naming it (OSError)
        pass
    FORMATS[fmt].writer(store, run_id, path)
    return path
