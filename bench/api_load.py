"""API under load while a test runs: run-read latency and the clock's lateness.

Runs the service exactly as ``rig serve`` does (uvicorn serving the app, the rig
session on its own "rig thread", simulated rig), starts a 10 Hz tow test, and lets a
loopback load generator in a separate process read a stored run at a fixed rate
(open loop: requests are sent on schedule whether or not earlier ones returned).
Prints one JSON document: the API's latency percentiles and the acquisition clock's
lateness during the load, next to its lateness over an equally long idle window.

    .venv/bin/python bench/api_load.py [--rate 200] [--seconds 15] [--read run|samples]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import multiprocessing as mp
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench.service import serve_in_thread, wait_job
from bench.timing import in_ms, percentile

TOKEN = "bench-token"
TARGET_API_P99_MS = 20.0
TARGET_CLOCK_P99_MS = 2.0


def _summary_ms(values: list[float]) -> dict:
    return {
        "n": len(values),
        "p50_ms": in_ms(percentile(values, 50)),
        "p99_ms": in_ms(percentile(values, 99)),
        "max_ms": in_ms(max(values) if values else None),
    }


# ---- the load generator (separate process) ------------------------------------------------
def _load(url: str, path: str, rate: float, seconds: float, out) -> None:
    import httpx

    async def main() -> dict:
        latencies: list[float] = []
        errors: dict[str, int] = {}
        late_sends = 0
        limits = httpx.Limits(max_connections=32, max_keepalive_connections=32)
        headers = {"Authorization": f"Bearer {TOKEN}"}
        async with httpx.AsyncClient(
            base_url=url, headers=headers, limits=limits, timeout=5.0
        ) as client:
            await client.get(path)  # warm the connection pool

            async def one() -> None:
                t0 = time.perf_counter()
                try:
                    r = await client.get(path)
                    if r.status_code != 200:
                        errors[str(r.status_code)] = errors.get(str(r.status_code), 0) + 1
                        return
                except httpx.HTTPError as err:
                    errors[type(err).__name__] = errors.get(type(err).__name__, 0) + 1
                    return
                latencies.append(time.perf_counter() - t0)

            n = int(rate * seconds)
            start = time.perf_counter() + 0.1
            tasks = []
            for i in range(n):
                due = start + i / rate
                delay = due - time.perf_counter()
                if delay > 0:
                    await asyncio.sleep(delay)
                elif delay < -0.01:
                    late_sends += 1
                tasks.append(asyncio.create_task(one()))
            try:  # every request has its own 5 s time-out; this bounds the pool's queue
                await asyncio.wait_for(asyncio.gather(*tasks), timeout=30)
            except TimeoutError:  # report what did not finish rather than no report at all
                errors["unfinished 30 s after the last send"] = sum(not t.done() for t in tasks)
            elapsed = time.perf_counter() - start
        return {
            "requests": n,
            "ok": len(latencies),
            "errors": errors,
            "late_sends": late_sends,
            "achieved_rate_per_s": round(n / elapsed, 1),
            "latencies": latencies,
        }

    out.put(asyncio.run(main()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=200.0, help="requests per second")
    parser.add_argument("--seconds", type=float, default=15.0, help="length of the load")
    parser.add_argument("--read", choices=("run", "samples"), default="run")
    parser.add_argument(
        "--no-realtime", action="store_true", help="clock thread at normal priority"
    )
    args = parser.parse_args()
    if not (0 < args.rate <= 2000 and 1 <= args.seconds <= 120):
        raise SystemExit("--rate must be in (0, 2000] and --seconds in [1, 120]")

    import logging

    import httpx

    logging.getLogger("thrusters").setLevel(logging.ERROR)
    with tempfile.TemporaryDirectory(prefix="api-bench-") as tmp:
        service, _app, server, thread, url = serve_in_thread(
            f"sqlite:///{tmp}/rig.db", TOKEN, not args.no_realtime, start_timeout_s=30
        )
        http = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {TOKEN}"})
        try:
            # a stored run to read
            first = http.post(
                "/api/jobs/tow", json={"force_n": 24.5, "max_time_s": 3, "baseline_s": 0.5}
            ).json()
            run_id = wait_job(http, first["id"], ("completed", "aborted", "failed"))["run_ids"][0]
            path = (
                f"/api/runs/{run_id}"
                if args.read == "run"
                else (f"/api/runs/{run_id}/samples?limit=500")
            )
            # the 10 Hz test that runs during the load
            test = http.post(
                "/api/jobs/tow",
                json={"force_n": 4.9, "max_time_s": 2 * args.seconds + 10, "baseline_s": 0.5},
            ).json()
            wait_job(http, test["id"], ("running",))
            while not http.get(f"/api/jobs/{test['id']}").json()["run_ids"]:
                time.sleep(0.05)
            acq = service.session.acquisition

            def window(seconds: float) -> tuple[list[float], int]:
                n0, over0 = len(acq.stats.lateness_s), acq.stats.overruns
                time.sleep(seconds)
                return list(acq.stats.lateness_s)[n0:], acq.stats.overruns - over0

            idle, idle_overruns = window(args.seconds)  # the test runs, no HTTP load

            ctx = mp.get_context("spawn")
            out = ctx.Queue()
            n0, over0 = len(acq.stats.lateness_s), acq.stats.overruns
            proc = ctx.Process(target=_load, args=(url, path, args.rate, args.seconds, out))
            proc.start()
            load = out.get(timeout=args.seconds + 60)
            proc.join(10)
            loaded = list(acq.stats.lateness_s)[n0:]
            loaded_overruns = acq.stats.overruns - over0
            job = http.get(f"/api/jobs/{test['id']}").json()
            http.post(f"/api/jobs/{test['id']}/abort")
            wait_job(http, test["id"], ("completed", "aborted", "failed"))
        finally:
            http.close()
            server.should_exit = True
            thread.join(20)

    api = _summary_ms(load.pop("latencies"))
    clock_loaded = _summary_ms(loaded) | {"overruns": loaded_overruns}
    result = {
        "bench": "api_load",
        "read": path.replace(run_id, "{run_id}"),
        "rate_target_per_s": args.rate,
        "seconds": args.seconds,
        "clock_thread_realtime": service.realtime_active,
        "test_running": {"kind": "tow", "state_during_load": job["state"], "rate_hz": acq.rate_hz},
        "load": load,
        "api_latency": api,
        "clock_lateness_under_load": clock_loaded,
        "clock_lateness_idle": _summary_ms(idle) | {"overruns": idle_overruns},
        "targets": {"api_p99_ms": TARGET_API_P99_MS, "clock_p99_ms": TARGET_CLOCK_P99_MS},
        "met": {
            "api_p99": api["p99_ms"] is not None and api["p99_ms"] < TARGET_API_P99_MS,
            "clock_p99": clock_loaded["p99_ms"] is not None
            and clock_loaded["p99_ms"] <= TARGET_CLOCK_P99_MS,
        },
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
