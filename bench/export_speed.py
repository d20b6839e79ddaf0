"""Time and size of each export format for one long run (default: 1 h at 10 Hz = 36,000
samples of BENBAM's ten channels, recorded on its rig file, in SQLite).

Prints one JSON document: per format the wall time of ``write_export`` (best of
``--repeat``), the file size and the bytes per sample; for Parquet and NetCDF also the
time pandas / xarray alone take to write the same frame / dataset (built beforehand, same
engine and encoding) and the ratio export ÷ that; ``load_seconds``: ``Store.load`` of the
run; plus the peak memory of the process (ru_maxrss) after all exports.

The samples are stored in batches of ``--batch-size`` (default: all in one call); a
recorder at 10 Hz flushing every 0.5 s stores batches of 5.

    .venv/bin/python bench/export_speed.py [--samples N] [--repeat R] [--batch-size B]
                                           [--formats csv,parquet,...]
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import platform
import resource
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from daq.export_formats import FORMATS, write_export
from daq.sample import Sample
from daq.store import Store
from daq.store.loaded_run import NETCDF_COMPRESSION
from tests.store.helpers import benbam_tow_run

CHANNELS = [
    "tow_position", "yaw_angle", "load_cell", "supply_voltage", "heartbeat", "plc_clock",
    "tow_release", "spin_release", "end_of_travel", "estop",
]  # fmt: skip


def make_samples(count: int) -> list[Sample]:
    """A tow-like recording at 10 Hz: every value a whole count of its channel's scale."""
    t0_mono, t0_wall = 81234.567891234, 1_795_000_000.123456
    out = []
    for seq in range(count):
        t = seq * 0.1
        values = {
            "tow_position": round(3e4 * t) * 1e-5,  # 0.3 m/s in 10 µm counts
            "yaw_angle": round(1e3 * math.sin(t)) * 1e-5,
            "load_cell": (24016 + seq % 7) * 1e-3,
            "supply_voltage": (2400 - seq % 3) * 0.01,
            "heartbeat": float(seq * 10),
            "plc_clock": (seq * 100) * 1e-3,
            "tow_release": float(seq > 5),
            "spin_release": 0.0,
            "end_of_travel": 0.0,
            "estop": 0.0,
        }
        out.append(Sample(seq, t0_mono + t, t0_wall + t, values))
    return out


def best_of(repeat: int, action: Callable[[], object]) -> float:
    """The shortest wall time of ``repeat`` calls of ``action``, s."""
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        action()
        times.append(time.perf_counter() - started)
    return min(times)


def library_writers(store: Store, run_id: str, folder: Path) -> dict[str, Callable[[], object]]:
    """For Parquet and NetCDF: pandas / xarray writing the frame / dataset the export
    writes (built here, untimed), with the export's engine and encoding."""
    loaded = store.load(run_id)
    frame, dataset = loaded.to_pandas(), loaded.to_xarray()
    encoding = {name: dict(NETCDF_COMPRESSION) for name in dataset.data_vars}
    return {
        "parquet": lambda: frame.to_parquet(folder / "lib.parquet", engine="pyarrow"),
        "netcdf": lambda: dataset.to_netcdf(
            folder / "lib.nc", engine="h5netcdf", encoding=encoding
        ),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=36_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--batch-size", type=int, default=0, help="0: all in one call")
    parser.add_argument("--formats", default=",".join(FORMATS), help="comma-separated")
    args = parser.parse_args()
    chosen = [name for name in args.formats.split(",") if name]
    if unknown := [name for name in chosen if name not in FORMATS]:
        parser.error(f"--formats: {unknown} not known; use some of {', '.join(FORMATS)}")
    with (
        tempfile.TemporaryDirectory(prefix="bench-export-") as folder,
        Store(f"sqlite:///{folder}/rig.db") as store,
    ):
        run_id = benbam_tow_run(store, CHANNELS)
        samples = make_samples(args.samples)
        batch = args.batch_size or len(samples) or 1
        started = time.perf_counter()
        for start in range(0, len(samples), batch):
            store.add_samples(run_id, samples[start : start + batch])
        store_seconds = time.perf_counter() - started
        del samples
        store.finish_run(run_id, "completed")
        load_seconds = best_of(args.repeat, lambda: store.load(run_id))
        libraries = library_writers(store, run_id, Path(folder))
        figures: dict[str, dict[str, float]] = {}
        for name in chosen:
            path = Path(folder) / f"run{FORMATS[name].suffix}"
            seconds = best_of(
                args.repeat, functools.partial(write_export, store, run_id, name, path)
            )
            size = path.stat().st_size
            figures[name] = {
                "seconds": round(seconds, 3),
                "bytes": size,
                "bytes_per_sample": round(size / args.samples, 1),
            }
            if name in libraries:
                library_seconds = best_of(args.repeat, libraries[name])
                figures[name]["library_seconds"] = round(library_seconds, 3)
                figures[name]["ratio_to_library"] = round(seconds / library_seconds, 2)
    print(
        json.dumps(
            {
                "samples": args.samples,
                "channels": len(CHANNELS),
                "repeat": args.repeat,
                "batch_size": batch,
                "store_seconds": round(store_seconds, 3),
                "load_seconds": round(load_seconds, 3),
                "formats": figures,
                "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
                "python": platform.python_version(),
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
