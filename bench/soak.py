"""Soak: the service as ``rig serve`` runs it, a sequence of tows back to back, 50 HTTP
requests per second, a live stream reader and one busy process beside it, for minutes.

Prints one JSON document: the acquisition clock's skipped slots and overruns, the
requests that failed, the stream events read, the runs recorded and how each ended, and the
process's resident memory after the first tow and at the end (growth in MB). Targets
(issue 19): 0 skipped slots, 0 request errors, RSS growth under 20 MB.

    .venv/bin/python bench/soak.py [--seconds 600] [--rate 50] [--no-busy]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.api_load import _load
from bench.service import serve_in_thread, wait_job

TOKEN = "bench-token"
TARGET_RSS_GROWTH_MB = 20.0
TOW = {"force_n": 24.5, "max_time_s": 4.0, "baseline_s": 0.5}
FINAL = ("completed", "aborted", "failed", "interrupted")


def _rss_mb() -> float:
    """This process's resident set, MB (Linux /proc)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


def _busy(seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:  # one core's worth of other work on the host
        pass


def _stream(url: str, seconds: float, out) -> None:
    """Read the live stream (samples at 10 Hz, job updates) for ``seconds``."""
    import httpx

    counts: dict[str, int] = {}
    errors = 0
    end = time.monotonic() + seconds
    headers = {"Authorization": f"Bearer {TOKEN}"}
    while time.monotonic() < end:
        try:
            with httpx.stream(
                "GET", f"{url}/api/stream?max_hz=10&max_s={max(1.0, end - time.monotonic()):.1f}",
                headers=headers, timeout=30,
            ) as r:  # fmt: skip
                for line in r.iter_lines():
                    if line.startswith("event: "):
                        kind = line[7:]
                        counts[kind] = counts.get(kind, 0) + 1
        except httpx.HTTPError:
            errors += 1
    out.put({"events": counts, "reconnect_errors": errors})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=600.0, help="length of the soak")
    parser.add_argument("--rate", type=float, default=50.0, help="HTTP requests per second")
    parser.add_argument("--no-busy", action="store_true", help="no busy process beside it")
    args = parser.parse_args()
    if not (10 <= args.seconds <= 3600 and 0 < args.rate <= 500):
        raise SystemExit("--seconds must be in [10, 3600] and --rate in (0, 500]")

    import logging

    import httpx

    logging.getLogger("thrusters").setLevel(logging.ERROR)
    ctx = mp.get_context("spawn")
    with tempfile.TemporaryDirectory(prefix="soak-") as tmp:
        service, _app, server, thread, url = serve_in_thread(
            f"sqlite:///{tmp}/rig.db", TOKEN, realtime=True, start_timeout_s=30
        )
        http = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {TOKEN}"})
        try:
            first = http.post("/api/jobs/tow", json=TOW).json()
            run_id = wait_job(http, first["id"], FINAL)["run_ids"][0]
            rss_start = _rss_mb()
            acq = service.session.acquisition
            stats0 = (acq.stats.ticks, acq.stats.skipped_slots, acq.stats.overruns)
            busy = None if args.no_busy else ctx.Process(target=_busy, args=(args.seconds + 30,))
            if busy:
                busy.start()
            loads, streams = ctx.Queue(), ctx.Queue()
            load = ctx.Process(
                target=_load, args=(url, f"/api/runs/{run_id}", args.rate, args.seconds, loads)
            )
            stream = ctx.Process(target=_stream, args=(url, args.seconds, streams))
            load.start()
            stream.start()
            ended: dict[str, int] = {}
            end = time.monotonic() + args.seconds
            while time.monotonic() < end - TOW["max_time_s"] - 5:
                job = http.post("/api/jobs/tow", json=TOW).json()
                state = wait_job(http, job["id"], FINAL, timeout_s=120)["state"]
                ended[state] = ended.get(state, 0) + 1
            load_result = loads.get(timeout=args.seconds + 90)
            stream_result = streams.get(timeout=120)
            for proc in (load, stream):
                proc.join(10)
            ticks = acq.stats.ticks - stats0[0]
            skipped = acq.stats.skipped_slots - stats0[1]
            overruns = acq.stats.overruns - stats0[2]
            lateness = acq.stats.lateness_percentiles()
            rss_end = _rss_mb()
        finally:
            if not args.no_busy and busy is not None:
                busy.terminate()
            http.close()
            server.should_exit = True
            thread.join(20)
    load_result.pop("latencies", None)
    growth = rss_end - rss_start
    errors = sum(load_result["errors"].values())
    print(
        json.dumps(
            {
                "bench": "soak",
                "seconds": args.seconds,
                "busy_process": not args.no_busy,
                "clock": {
                    "ticks": ticks,
                    "skipped_slots": skipped,
                    "overruns": overruns,
                    "lateness_p99_ms": round(1000 * lateness["p99_s"], 3),
                    "realtime": service.realtime_active,
                },
                "runs_ended": ended,
                "http": load_result,
                "stream": stream_result,
                "rss_mb": {"after_first_tow": round(rss_start, 1), "end": round(rss_end, 1)},
                "rss_growth_mb": round(growth, 1),
                "met": {
                    "no_skipped_slots": skipped == 0,
                    "no_request_errors": errors == 0,
                    "rss_growth": growth < TARGET_RSS_GROWTH_MB,
                    "every_run_completed": set(ended) == {"completed"},
                },
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
