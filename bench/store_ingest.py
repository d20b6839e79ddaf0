"""Batched sample ingest rate of daq.store (target ≥ 200,000 samples/s into SQLite).

Prints one JSON document. Samples are built before timing; the timed part is
``Store.add_samples`` (packing + executemany/COPY + commit), batch after batch, plus a
read-back check that every sample arrived. ``sqlite.recorder`` is the same through a
RunRecorder (put from the event loop, flushes in a worker thread) with the worst loop lag.
``sqlite.raw_executemany`` is the rate to compare with: the plain ``sqlite3`` module
inserting the same samples as ready-made rows, one per sample (seq, times, quality, stale,
channels packed as one float64 BLOB, built before timing), same pragmas and batches, one
commit per batch; ``ratios`` divide the store's and the recorder's rates by it.

    .venv/bin/python bench/store_ingest.py [--samples N] [--batch-size B] [--channels C]
                                           [--postgres-url URL | --postgres-temp]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import platform
import sqlite3
import struct
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from daq.sample import Sample
from daq.store import RunRecorder, Store

STANDARD = ["tow_position", "yaw_angle", "load_cell", "supply_voltage", "heartbeat", "plc_clock"]


def channel_names(count: int) -> list[str]:
    """The standard channel names, then ``extra_N`` up to ``count``."""
    return (STANDARD + [f"extra_{i}" for i in range(max(0, count - len(STANDARD)))])[:count]


def make_samples(count: int, names: list[str]) -> list[Sample]:
    """``count`` samples at 100 Hz with distinct values."""
    t0 = time.time()
    return [
        Sample(
            seq, seq * 0.01, t0 + seq * 0.01, {n: math.sin(seq + i) for i, n in enumerate(names)}
        )
        for seq in range(count)
    ]


def measure(url: str, samples: list[Sample], names: list[str], batch_size: int) -> dict:
    """Ingest ``samples`` into a new run at ``url``; returns the figures."""
    with Store(url) as store:
        run_id = store.create_run(
            kind="tow",
            parameters={"bench": True},
            channel_names=names,
            rig_name="bench",
            vehicle="bench",
            rig_toml="",
        )
        started = time.perf_counter()
        for i in range(0, len(samples), batch_size):
            store.add_samples(run_id, samples[i : i + batch_size])
        seconds = time.perf_counter() - started
        read_started = time.perf_counter()
        table = store.samples(run_id)
        read_seconds = time.perf_counter() - read_started
        if len(table) != len(samples) or table.channels[names[-1]][-1] != math.sin(
            len(samples) - 1 + len(names) - 1
        ):
            raise SystemExit("read-back mismatch: samples were lost or corrupted")
        return {
            "backend": store.backend,
            "samples": len(samples),
            "seconds": round(seconds, 4),
            "samples_per_s": round(len(samples) / seconds),
            "batch_size": batch_size,
            "batches": math.ceil(len(samples) / batch_size),
            "mean_batch_ms": round(1000 * seconds / math.ceil(len(samples) / batch_size), 3),
            "read_back_samples_per_s": round(len(samples) / read_seconds),
            "target_samples_per_s": 200_000,
        }


def measure_raw(path: str, samples: list[Sample], names: list[str], batch_size: int) -> dict:
    """Insert ``samples`` with the plain sqlite3 module, one row per sample, the rows built
    (channels packed) before timing: ``batch_size`` rows per executemany and commit."""
    pack = struct.Struct(f"<{len(names)}d").pack
    rows = [
        (1, s.seq, s.t_mono, s.t_wall, int(s.quality), ",".join(s.stale) or None,
         pack(*[s.channels[n] for n in names]))
        for s in samples
    ]  # fmt: skip
    db = sqlite3.connect(path)
    try:
        db.execute("PRAGMA journal_mode=WAL")
        db.execute("PRAGMA synchronous=NORMAL")
        db.execute(
            "CREATE TABLE samples (run_id INTEGER, seq INTEGER, t_mono REAL, t_wall REAL, "
            "quality INTEGER, stale TEXT, channel_values BLOB, PRIMARY KEY (run_id, seq)) "
            "WITHOUT ROWID"
        )
        started = time.perf_counter()
        for i in range(0, len(rows), batch_size):
            with db:
                db.executemany(
                    "INSERT INTO samples VALUES (?, ?, ?, ?, ?, ?, ?)", rows[i : i + batch_size]
                )
        seconds = time.perf_counter() - started
    finally:
        db.close()
    return {
        "samples": len(samples),
        "seconds": round(seconds, 4),
        "samples_per_s": round(len(samples) / seconds),
        "batch_size": batch_size,
    }


def measure_recorder(url: str, samples: list[Sample], names: list[str]) -> dict:
    """Push ``samples`` through a RunRecorder (put → batched flush in a worker thread) and
    time until ``close()`` returns; also the worst event-loop lag seen meanwhile."""

    async def go() -> dict:
        with Store(url) as store:
            run_id = store.create_run(
                kind="tow",
                parameters={"bench": "recorder"},
                channel_names=names,
                rig_name="bench",
                vehicle="bench",
                rig_toml="",
            )
            recorder = RunRecorder(store, run_id, flush_interval_s=0.1, max_queue=len(samples))
            flusher = asyncio.create_task(recorder.run())
            loop = asyncio.get_running_loop()
            worst_lag = 0.0
            started = time.perf_counter()
            for i in range(0, len(samples), 1000):  # 1000 samples per 1 ms "tick"
                for sample in samples[i : i + 1000]:
                    recorder.put(sample)
                expected = loop.time() + 0.001
                await asyncio.sleep(0.001)
                worst_lag = max(worst_lag, loop.time() - expected)
            await recorder.close()
            await flusher
            seconds = time.perf_counter() - started
            if store.sample_count(run_id) != len(samples):
                raise SystemExit("recorder lost samples")
            return {
                "samples": len(samples),
                "seconds": round(seconds, 4),
                "samples_per_s": round(len(samples) / seconds),
                "batches": recorder.stats.batches,
                "max_flush_s": round(recorder.stats.max_flush_s, 4),
                "max_event_loop_lag_s": round(worst_lag, 4),
            }

    return asyncio.run(go())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--samples", type=int, default=500_000)
    parser.add_argument("--batch-size", type=int, default=10_000)
    parser.add_argument("--channels", type=int, default=6)
    parser.add_argument("--postgres-url", help="also measure this (empty) PostgreSQL database")
    parser.add_argument(
        "--postgres-temp",
        action="store_true",
        help="also measure a throwaway local PostgreSQL cluster (tests/support/pg.py)",
    )
    args = parser.parse_args()
    names = channel_names(args.channels)
    samples = make_samples(args.samples, names)
    with tempfile.TemporaryDirectory() as folder:
        sqlite = measure(f"sqlite:///{folder}/bench.db", samples, names, args.batch_size)
        sqlite["meets_target"] = sqlite["samples_per_s"] >= 200_000
        sqlite["recorder"] = measure_recorder(
            f"sqlite:///{folder}/recorder.db", samples[:200_000], names
        )
        raw = measure_raw(f"{folder}/raw.db", samples, names, args.batch_size)
        sqlite["raw_executemany"] = raw
        sqlite["ratios"] = {
            "store_to_raw": round(sqlite["samples_per_s"] / raw["samples_per_s"], 2),
            "recorder_to_raw": round(sqlite["recorder"]["samples_per_s"] / raw["samples_per_s"], 2),
        }
    result = {
        "benchmark": "store_ingest",
        "channels": len(names),
        "python": platform.python_version(),
        "sqlite": sqlite,
    }
    if args.postgres_url:
        result["postgresql"] = measure(args.postgres_url, samples, names, args.batch_size)
    elif args.postgres_temp:
        from tests.support.pg import start_postgres

        server = start_postgres()
        try:
            url = server.create_database("bench")
            result["postgresql"] = measure(url, samples, names, args.batch_size)
        finally:
            server.stop()
    # Top-level summary fields for scripts: the SQLite figures.
    for key in ("samples", "seconds", "samples_per_s", "batch_size"):
        result[key] = sqlite[key]
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
