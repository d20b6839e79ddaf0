"""Soak: the service as ``rig serve`` runs it, a sequence of tows back to back, 50 HTTP
requests per second, a live stream reader and two busy processes beside it, for minutes;
every fifth tow is estimated as it ends (the fit runs in the analysis worker process).

Prints one JSON document: the acquisition clock's skipped slots, overruns and failed polls,
the samples lost (queue drops, stored samples short of the runs' ticks), the requests that
failed, the stream events read, the runs recorded and how each ended, the estimation jobs,
and the process's resident memory after the first tow and at the end (growth in MB).
Targets (issues 19 and 35): 0 skipped slots, 0 failed polls, 0 lost samples, 0 request
errors, RSS growth under 20 MB.

    .venv/bin/python bench/soak.py [--seconds 600] [--rate 50] [--busy 2]
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
from bench.simproc import busy_neighbours

TOKEN = "bench-token"
TARGET_RSS_GROWTH_MB = 20.0
TOW = {"force_n": 24.5, "max_time_s": 4.0, "baseline_s": 0.5}
FINAL = ("completed", "aborted", "failed", "interrupted")
#: How long after its last tow the soak waits for the load and stream processes' reports
#: (the load's requests time out in 5 s and it reports 30 s after its last send at most).
REPORT_WAIT_S = 120.0


def rss_mb() -> float:
    """This process's resident set, MB (Linux /proc)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


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
    parser.add_argument("--busy", type=int, default=2, help="busy processes beside it")
    args = parser.parse_args()
    if not (10 <= args.seconds <= 3600 and 0 < args.rate <= 500 and 0 <= args.busy <= 8):
        raise SystemExit(
            f"--seconds must be in [10, 3600] (got {args.seconds:g}), --rate in (0, 500] "
            f"(got {args.rate:g}), --busy in [0, 8] (got {args.busy})"
        )

    import logging

    import httpx

    logging.getLogger("thrusters").setLevel(logging.ERROR)
    ctx = mp.get_context("spawn")
    with tempfile.TemporaryDirectory(prefix="soak-") as tmp:
        service, app, server, thread, url = serve_in_thread(
            f"sqlite:///{tmp}/rig.db", TOKEN, realtime=True, start_timeout_s=30
        )
        http = httpx.Client(base_url=url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=30)
        load_result: dict = {"errors": {"no report from the load process": 1}}
        stream_result: dict = {"error": "no report from the stream reader"}
        harness: list[str] = []  # what went wrong in the bench itself (never a crash)
        ended: dict[str, int] = {}
        estimations: list[str] = []  # job ids
        run_ids: list[str] = []
        try:
            first = http.post("/api/jobs/tow", json=TOW).json()
            run_id = wait_job(http, first["id"], FINAL)["run_ids"][0]
            rss_start = rss_mb()
            acq = service.session.acquisition
            stats = acq.stats
            stats0 = (stats.ticks, stats.skipped_slots, stats.overruns, stats.failed_polls)
            dropped0 = dict(stats.dropped)
            loads, streams = ctx.Queue(), ctx.Queue()
            path = f"/api/runs/{run_id}"
            load = ctx.Process(target=_load, args=(url, path, args.rate, args.seconds, loads))
            stream = ctx.Process(target=_stream, args=(url, args.seconds, streams))
            with busy_neighbours(args.busy, args.seconds + 120):
                load.start()
                stream.start()
                end = time.monotonic() + args.seconds
                while time.monotonic() < end - TOW["max_time_s"] - 5:
                    try:
                        _tow_and_estimate(http, ended, estimations, run_ids)
                    except (httpx.HTTPError, KeyError, ValueError, SystemExit) as err:
                        harness.append(f"{type(err).__name__}: {err}"[:200])
                        time.sleep(1.0)  # host pacing: let a refused start clear
                for queue, name in ((loads, "load"), (streams, "stream")):
                    try:
                        got = queue.get(timeout=REPORT_WAIT_S)
                    except Exception as err:  # queue.Empty: the child died or hung
                        harness.append(f"no {name} report: {type(err).__name__}")
                        continue
                    if name == "load":
                        load_result = got
                    else:
                        stream_result = got
                for proc in (load, stream):
                    proc.join(10)
                    if proc.is_alive():
                        proc.terminate()
            ticks = stats.ticks - stats0[0]
            skipped = stats.skipped_slots - stats0[1]
            overruns = stats.overruns - stats0[2]
            failed_polls = stats.failed_polls - stats0[3]
            dropped = {k: v - dropped0.get(k, 0) for k, v in stats.dropped.items()}
            lateness = stats.lateness_percentiles()
            estimated: dict[str, int] = {}  # the neighbours are gone: the last job ends
            for job_id in estimations:
                state = wait_job(http, job_id, FINAL, timeout_s=600)["state"]
                estimated[state] = estimated.get(state, 0) + 1
            missing = sum(_missing_samples(service.store, rid) for rid in run_ids)
            rss_end = rss_mb()
            worker = getattr(app.state.runner.analysis.executor, "worker", None)
        finally:
            http.close()
            server.should_exit = True
            thread.join(20)
    load_result.pop("latencies", None)
    growth = rss_end - rss_start
    errors = sum(load_result["errors"].values())
    lost = missing + dropped.get("run-recorder", 0)
    print(
        json.dumps(
            {
                "bench": "soak",
                "seconds": args.seconds,
                "busy_processes": args.busy,
                "clock": {
                    "ticks": ticks,
                    "skipped_slots": skipped,
                    "overruns": overruns,
                    "failed_polls": failed_polls,
                    "dropped": dropped,
                    "lateness_p99_ms": round(1000 * lateness["p99_s"], 3),
                    "realtime": service.realtime_active,
                },
                "runs_ended": ended,
                "samples_lost": {"missing_in_runs": missing, "recorder_drops": lost - missing},
                "estimations_ended": estimated,
                "analysis_worker": worker and {"pid": worker[0], "nice": worker[1]},
                "http": load_result,
                "stream": stream_result,
                "harness_errors": harness,
                "rss_mb": {"after_first_tow": round(rss_start, 1), "end": round(rss_end, 1)},
                "rss_growth_mb": round(growth, 1),
                "met": {
                    "no_skipped_slots": skipped == 0,
                    "no_failed_polls": failed_polls == 0,
                    "no_lost_samples": lost == 0,
                    "no_request_errors": errors == 0,
                    "rss_growth": growth < TARGET_RSS_GROWTH_MB,
                    "every_run_completed": set(ended) == {"completed"},
                    "every_estimation_completed": set(estimated) <= {"completed"},
                },
            },
            indent=2,
        )
    )


def _tow_and_estimate(
    http, ended: dict[str, int], estimations: list[str], run_ids: list[str]
) -> None:
    """One tow; every fifth one estimated (in the analysis worker, at nice 5) unless the
    last estimation is still running: not waited for, its ending is read at the end."""
    job = http.post("/api/jobs/tow", json=TOW).json()
    done = wait_job(http, job["id"], FINAL, timeout_s=120)
    ended[done["state"]] = ended.get(done["state"], 0) + 1
    run_ids += done.get("run_ids") or []
    busy = estimations and http.get(f"/api/jobs/{estimations[-1]}").json()["state"] not in FINAL
    if done["state"] == "completed" and len(run_ids) % 5 == 0 and not busy:
        body = {"run_ids": run_ids[-1:], "search_effects": True}
        estimations.append(http.post("/api/jobs/estimation", json=body).json()["id"])


def _missing_samples(store, run_id: str) -> int:
    """Slots inside a run with no stored sample (a gap in ``seq``)."""
    seq = store.samples(run_id).seq
    return 0 if len(seq) == 0 else int(seq[-1] - seq[0] + 1 - len(seq))


if __name__ == "__main__":
    main()
