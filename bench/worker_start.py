"""From ``ProcessExecutor.start()`` to its first task done: what an analysis worker costs
before it works (issue 33: a job's worker ready fast; issue 34 item 5: the suite's children).

Each case runs in a fresh process of this script on the checkout ``--src`` (default: this
one; another one, e.g. ``git archive BASE | tar -x -C DIR``, to compare), so its process
starts no worker before the case does:

* ``first``: a new ``ProcessExecutor``: wall seconds from ``start()`` to a first trivial task
  (``os.getpid``) done in its worker, and the CPU seconds the worker process and, where the
  checkout forks workers from a preloaded server, that server had spent by then;
* ``kernels_cpu_s``: then the CPU seconds the worker spends making the estimator's compiled
  kernel ready (``compiled_warm_up.warm_up``: loading it from numba's cache) — what its first
  estimate adds;
* ``next``: a second ``ProcessExecutor`` in the same process (a test's own, or the worker
  that replaces a killed one), timed the same way;
* ``memory_mb``: resident and proportional set size (RSS, PSS) of this process, the worker
  and the server, once the worker is idle.

Each checkout is byte-compiled and run once untimed first (numba's cache filled), as an
install leaves it. ``--repeat`` runs the checkouts alternately (base, ours, base, …); prints
one JSON document with each run and each figure's median per checkout, and ours over base
where two are given.
Wall seconds on the 2-core machine depend on its load: read them beside the CPU seconds.

    .venv/bin/python bench/worker_start.py [--repeat 3] [--src DIR ...]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
TICKS = os.sysconf("SC_CLK_TCK")


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS


def _memory_mb(pid: int | None) -> dict[str, float] | None:
    """RSS and PSS of process ``pid`` (MB), None for no process."""
    if pid is None:
        return None
    found = {}
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("Rss", "Pss"):
            found[key.lower()] = round(int(value.split()[0]) / 1024, 1)
    return found


def _server_of(worker: int) -> int | None:
    """The fork server ``worker`` was forked from: its parent, when that is not this
    process (a spawned worker's parent is this process: no server)."""
    parent = int(Path(f"/proc/{worker}/stat").read_text().rsplit(")", 1)[1].split()[1])
    return None if parent == os.getpid() else parent


def _timed_start(executor: Any, server: int | None) -> dict[str, Any]:
    """Start ``executor`` and run a trivial task: wall and CPU seconds it took."""
    server_cpu = _cpu_s(server) if server is not None else 0.0
    started = time.perf_counter()
    executor.start()
    pid = executor.call(None, os.getpid)
    wall = time.perf_counter() - started
    server = server or _server_of(pid)
    spent = _cpu_s(server) - server_cpu if server is not None else 0.0
    return {
        "wall_s": round(wall, 3),
        "worker_cpu_s": round(_cpu_s(pid), 3),
        "server_cpu_s": round(spent, 3),
        "cpu_s": round(_cpu_s(pid) + spent, 3),
        "pid": pid,
        "server": server,
    }


def one_case() -> dict[str, Any]:
    """In a fresh process: the figures of one run (``first``, ``kernels_cpu_s``, ``next``)."""
    from api.core.analysis_executor import ProcessExecutor
    from estimation.motion.compiled_warm_up import warm_up

    first_executor, next_executor = ProcessExecutor(), ProcessExecutor()
    try:
        first = _timed_start(first_executor, None)
        kernels = first_executor.call(None, warm_up)
        following = _timed_start(next_executor, first["server"])
        memory = {
            "service": _memory_mb(os.getpid()),
            "worker": _memory_mb(first["pid"]),
            "server": _memory_mb(first["server"]),
        }
    finally:
        first_executor.close()
        next_executor.close()
    for case in (first, following):
        del case["pid"], case["server"]
    return {"first": first, "kernels_cpu_s": round(kernels, 3), "next": following} | {
        "memory_mb": memory
    }


def _run(src: Path) -> dict[str, Any]:
    """One case in a fresh process on the checkout ``src``."""
    done = subprocess.run(
        [sys.executable, str(Path(__file__).resolve()), "--case"],
        cwd=src,
        env=os.environ | {"PYTHONPATH": str(src)},
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise SystemExit(f"{src}: {done.stderr.strip()[-2000:]}")
    return dict(json.loads(done.stdout.strip().splitlines()[-1]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--src", type=Path, action="append", help="a checkout (repeatable)")
    parser.add_argument("--case", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:  # a child: one run on the checkout on sys.path
        print(json.dumps(one_case()))
        return
    # here, not at the top: a child imports the checkout on its PYTHONPATH, not this one
    sys.path.append(str(ROOT))
    from bench.checkouts import alternated

    sources = [src.resolve() for src in args.src or [ROOT]]
    doc: dict[str, Any] = {"repeat": args.repeat} | alternated(sources, _run, args.repeat)
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
