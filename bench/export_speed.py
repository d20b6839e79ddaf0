"""Time and size of each export format for one long run (default: 1 h at 10 Hz = 36,000
samples of BENBAM's ten channels, recorded on its rig file, in SQLite).

Prints one JSON document: per format the wall time of ``write_export`` (best of
``--repeat``), the file size and the bytes per sample; plus the peak memory of the
process (ru_maxrss) after all exports.

    .venv/bin/python bench/export_speed.py [--samples N] [--repeat R]
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from daq.export_formats import FORMATS, write_export
from daq.sample import Sample
from daq.store import Store
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=36_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with (
        tempfile.TemporaryDirectory(prefix="bench-export-") as folder,
        Store(f"sqlite:///{folder}/rig.db") as store,
    ):
        run_id = benbam_tow_run(store, CHANNELS)
        store.add_samples(run_id, make_samples(args.samples))
        store.finish_run(run_id, "completed")
        figures = {}
        for name, spec in FORMATS.items():
            path = Path(folder) / f"run{spec.suffix}"
            times = []
            for _ in range(args.repeat):
                started = time.perf_counter()
                write_export(store, run_id, name, path)
                times.append(time.perf_counter() - started)
            size = path.stat().st_size
            figures[name] = {
                "seconds": round(min(times), 3),
                "bytes": size,
                "bytes_per_sample": round(size / args.samples, 1),
            }
    print(
        json.dumps(
            {
                "samples": args.samples,
                "channels": len(CHANNELS),
                "repeat": args.repeat,
                "formats": figures,
                "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
                "python": platform.python_version(),
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
