"""Resident memory of the rig service under generated API requests, pass after pass.

A child process serves the simulated rig as ``rig serve`` does (``RigService``,
``create_app``, uvicorn), with ``tracemalloc`` on (which adds to every figure). First each
heavy path is used once and its RSS growth recorded (a tow; an estimation with its report
figures: matplotlib; the run exported as CSV, JSON, NetCDF: pandas, xarray, h5netcdf; and
Parquet: pyarrow). Then this process sends it, ``--passes`` times over, schemathesis'
generated requests for every operation of its OpenAPI document (``--examples`` per
operation, valid and invalid, with the token; an emergency stop after each operation ends
the jobs it started), recording the RSS growth of each pass (measured before the pass's
``tracemalloc`` snapshot, whose own cost is not counted) and of each operation. The Python
objects alive after each pass are compared, first to last, by the most recent frame in this
project's code, so a growing registry or cache would be named.

Finding (issue 19, the 171 → 291 MB under schemathesis): the growth is the one-time loading
of the report and export libraries on their first use; after that a pass adds about 1 MB
and the objects alive stay flat. Prints one JSON document. Usage:
``.venv/bin/python bench/api_memory.py [--passes 3] [--examples 8] [--arena-max N]``
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

TOKEN = "bench-memory-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
#: Our packages: an allocation is attributed to its first frame in one of them.
OURS = tuple(str(ROOT / p) + os.sep for p in ("api", "daq", "estimation", "thrusters"))


def _serve(folder: Path) -> None:
    """The child: the service on a free port; prints the URL; SIGUSR1 dumps a snapshot."""
    import socket

    import uvicorn

    from api.core.service import RigService
    from api.http.app import create_app
    from daq.session import RigSource

    logging.getLogger("pymodbus").setLevel(logging.CRITICAL)  # as the rig command does
    tracemalloc.start(8)
    snapshots = iter(range(1_000_000))

    def dump(*_: object) -> None:
        tracemalloc.take_snapshot().dump(str(folder / f"snap-{next(snapshots)}.bin"))
        print(f"dumped {tracemalloc.get_traced_memory()[0] / 1e6:.1f}", flush=True)

    signal.signal(signal.SIGUSR1, dump)
    service = RigService(RigSource.load(), f"sqlite:///{folder / 'rig.db'}", owner="bench")
    (folder / "reports").mkdir()
    app = create_app(service, token=TOKEN, report_root=folder / "reports")
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    print(f"http://127.0.0.1:{sock.getsockname()[1]}", flush=True)
    config = uvicorn.Config(app, log_level="error", access_log=False, lifespan="on")
    uvicorn.Server(config).run(sockets=[sock])


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/statm", encoding="ascii") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


def _caller(op: Any, examples: int, sent: list[int]) -> Any:
    """A hypothesis test sending ``examples`` generated requests of ``op``."""
    from hypothesis import HealthCheck, given, settings

    stream = op.path == "/api/stream"

    @given(case=op.as_strategy())
    @settings(
        max_examples=examples,
        deadline=None,
        suppress_health_check=list(HealthCheck),
        derandomize=True,
        database=None,
    )
    def call(case: Any) -> None:
        if stream and isinstance(case.query, dict):
            case.query = case.query | {"max_s": 0.3}  # bounded: streams never end otherwise
        # a timeout or a closed connection is the server's business, not this count's
        with contextlib.suppress(Exception):
            case.call(headers=AUTH, timeout=10)
        sent[0] += 1

    return call


def _one_pass(url: str, examples: int, pid: int, grew: dict[str, float]) -> int:
    """Every operation's generated requests once, adding each one's RSS growth (MB) of the
    service ``pid`` to ``grew``; returns how many requests were sent."""
    import httpx
    import schemathesis

    schema = schemathesis.openapi.from_url(f"{url}/openapi.json", timeout=120)
    sent = [0]
    for result in schema.get_all_operations():
        op = result.ok()
        before = _rss_mb(pid)
        _caller(op, examples, sent)()
        httpx.post(f"{url}/api/rig/emergency-stop", headers=AUTH, timeout=10)
        grew[op.label] = grew.get(op.label, 0.0) + _rss_mb(pid) - before
    return sent[0]


def _first_use(url: str, pid: int) -> dict[str, float]:
    """The service's RSS growth (MB) when each heavy path is first used: a short tow, an
    estimation with its report figures (matplotlib), the run exported in each format
    (pandas, xarray with h5netcdf, pyarrow)."""
    import httpx

    grown: dict[str, float] = {}
    with httpx.Client(base_url=url, headers=AUTH, timeout=120) as http:

        def job(path: str, body: dict[str, Any]) -> dict[str, Any]:
            job_id = http.post(path, json=body).json()["id"]
            while True:
                state = http.get(f"/api/jobs/{job_id}").json()
                if state["state"] in ("completed", "aborted", "failed"):
                    return state
                time.sleep(0.2)  # host pacing: the job runs on the service

        steps: list[tuple[str, Any]] = [
            ("tow", lambda: job("/api/jobs/tow", {"force_n": 24.5, "max_time_s": 1.5})),
        ]
        run: dict[str, str] = {}
        for name, step in steps:
            before = _rss_mb(pid)
            run["id"] = step()["run_ids"][0]
            grown[name] = round(_rss_mb(pid) - before, 1)
        later = [
            ("estimation + report", lambda: job("/api/jobs/estimation", {"run_ids": [run["id"]]}))
        ]
        later += [
            (
                f"export {fmt}",
                lambda fmt=fmt: http.get(f"/api/runs/{run['id']}/export?format={fmt}"),
            )
            for fmt in ("csv", "json", "netcdf", "parquet")
        ]
        for name, step in later:
            before = _rss_mb(pid)
            step()
            grown[name] = round(_rss_mb(pid) - before, 1)
    return grown


def _top_growth(first: Path, last: Path, count: int = 12) -> list[dict[str, Any]]:
    """Allocations alive at ``last`` minus those at ``first``, by first frame of ours."""
    grown: dict[str, list[float]] = {}
    stats = tracemalloc.Snapshot.load(str(last)).compare_to(
        tracemalloc.Snapshot.load(str(first)), "traceback"
    )
    for stat in stats:
        ours = (f for f in reversed(stat.traceback) if f.filename.startswith(OURS))
        frame = next(ours, None)  # the most recent frame in this project
        where = (
            f"{Path(frame.filename).relative_to(ROOT)}:{frame.lineno}"
            if frame
            else "(outside the project)"
        )
        entry = grown.setdefault(where, [0.0, 0.0])
        entry[0] += stat.size_diff / 1e6
        entry[1] += stat.count_diff
    ranked = sorted(grown.items(), key=lambda kv: -kv[1][0])[:count]
    return [{"where": k, "mb": round(v[0], 2), "blocks": int(v[1])} for k, v in ranked]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--passes", type=int, default=3)
    parser.add_argument("--examples", type=int, default=12, help="requests per operation")
    parser.add_argument(
        "--arena-max", type=int, help="MALLOC_ARENA_MAX for the service (glibc's default: 8/core)"
    )
    parser.add_argument("--serve", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.serve:
        _serve(Path(args.serve))
        return
    with tempfile.TemporaryDirectory(prefix="bench-memory-") as tmp:
        folder = Path(tmp)
        env = os.environ | {"RIG_SPILL_DIR": str(folder / "spill"), "PYTHONUNBUFFERED": "1"}
        if args.arena_max:
            env["MALLOC_ARENA_MAX"] = str(args.arena_max)
        child = subprocess.Popen(
            [sys.executable, __file__, "--serve", str(folder)],
            stdout=subprocess.PIPE,
            text=True,
            env=env,
            cwd=ROOT,
        )
        try:
            url = child.stdout.readline().strip()
            assert url.startswith("http://"), url
            import httpx

            for _ in range(200):  # until it answers (uvicorn has no ready event to wait on)
                try:
                    if httpx.get(f"{url}/api/health", timeout=1).status_code == 200:
                        break
                except httpx.HTTPError:
                    time.sleep(0.1)  # host pacing while uvicorn binds
            first_use = _first_use(url, child.pid)
            rss = [round(_rss_mb(child.pid), 1)]
            sent = []
            seconds: list[float] = []
            traced: list[float] = []
            by_operation: dict[str, float] = {}
            growth: list[float] = []
            for number in range(args.passes):
                t0, before = time.monotonic(), _rss_mb(child.pid)
                sent.append(_one_pass(url, args.examples, child.pid, by_operation))
                seconds.append(round(time.monotonic() - t0, 1))
                rss.append(round(_rss_mb(child.pid), 1))
                growth.append(round(rss[-1] - before, 1))
                # The snapshot (taken after the pass was measured) costs the service memory
                # of its own: the next pass is measured from after it.
                child.send_signal(signal.SIGUSR1)
                answer = child.stdout.readline().split()
                assert answer[0] == "dumped", answer
                traced.append(float(answer[1]))
                print(f"pass {number + 1}: {sent[-1]} requests, +{growth}", file=sys.stderr)
        finally:
            child.terminate()
            child.wait(30)
        out: dict[str, Any] = {
            "bench": "api_memory",
            "first_use_rss_growth_mb": first_use,
            "examples_per_operation": args.examples,
            "requests_per_pass": sent,
            "seconds_per_pass": seconds,
            "rss_mb_after_start_then_each_pass": rss,  # each after a snapshot's cost
            "rss_growth_mb_per_pass": growth,
            "python_objects_alive_mb_after_each_pass": traced,
            "malloc_arena_max": args.arena_max,
            "rss_growth_mb_by_operation_top": {
                k: round(v, 1) for k, v in sorted(by_operation.items(), key=lambda kv: -kv[1])[:8]
            },
        }
        if args.passes > 1:
            out["alive_growth_first_to_last_pass"] = _top_growth(
                folder / "snap-0.bin", folder / f"snap-{args.passes - 1}.bin"
            )
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
