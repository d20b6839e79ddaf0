"""The formats a run can be exported in, one table for the CLI, the API and the UI:
name → file suffix, media type and writer. Light to import (the CLI lists the formats in
its help without loading the store)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from daq.store.store import Store


@dataclass(frozen=True)
class ExportFormat:
    """One export format: ``suffix`` of its files, its ``media_type``, whether it is
    ``binary``, and what it holds."""

    name: str
    suffix: str
    media_type: str
    binary: bool
    description: str


FORMATS: dict[str, ExportFormat] = {
    f.name: f
    for f in (
        ExportFormat(
            "csv", ".csv", "text/csv", False,
            "comment lines (run description, units), then a row per sample",
        ),
        ExportFormat(
            "json", ".json", "application/json", False,
            "one document: run, units, samples, events, results",
        ),
        ExportFormat(
            "netcdf", ".nc", "application/x-netcdf", True,
            "NetCDF-4 for xarray: units per variable, the run as global attributes",
        ),
        ExportFormat(
            "parquet", ".parquet", "application/vnd.apache.parquet", True,
            "Parquet for pandas/arrow: units in the schema, the run in df.attrs",
        ),
    )
}  # fmt: skip


def export_file_name(run_id: str, fmt: str) -> str:
    """``run-<first 8 of the id><suffix>``."""
    return f"run-{run_id[:8]}{FORMATS[fmt].suffix}"


def write_export(store: Store, run_id: str, fmt: str, path: str | Path) -> Path:
    """Write the run in format ``fmt`` (a key of ``FORMATS``) to ``path``."""
    if fmt not in FORMATS:
        raise ValueError(f"format: {fmt!r} is not allowed; use one of {', '.join(FORMATS)}")
    path = Path(path)
    if fmt in ("csv", "json"):
        from daq.store.csv_export import export_run_csv, export_run_json

        writer: Callable = export_run_csv if fmt == "csv" else export_run_json
        with open(path, "w", encoding="utf-8", newline="") as f:
            writer(store, run_id, f)
        return path
    with open(path, "wb"):  # a path that cannot be written fails here, naming it (OSError)
        pass
    run = store.load(run_id)  # pandas/xarray/pyarrow are imported by the writer
    return run.to_netcdf(path) if fmt == "netcdf" else run.to_parquet(path)
