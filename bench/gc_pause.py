"""The longest pause of a rig-driving process while its thrusters are armed, under load.

Each mode runs in a fresh child process that loads what ``rig serve`` loads (the web app,
estimation, the store), opens the simulated BENBAM rig (clock, PLC, thruster link) and arms
its thrusters, then for ``--seconds`` keeps a loaded heap busy: a worker thread builds and
drops request-like structures (dicts and lists, some cyclic, some living a few seconds)
while a 100 Hz "heartbeat" thread, like the thruster supervisor, records how late it
wakes. The pause is that lateness: a full garbage collection holds the GIL the heartbeat
needs. Modes:

* ``plain``: as the CLI was before issue 19: no ``gc.freeze()``, collections as CPython
  schedules them (the session's hold on full collections is switched off);
* ``guarded``: ``gc.freeze()`` after start-up and no full collection while armed
  (``daq.collector``), as ``rig serve`` and ``rig tow`` now run.

Prints one JSON document: per mode the heartbeat's longest and p99 lateness (s), the full
(generation 2) collections while armed and the longest of them (s), the young ones, and
how much the resident memory grew while armed (cyclic garbage waits for the disarm).
Usage: ``.venv/bin/python bench/gc_pause.py [--seconds 8] [--heap 300000]``
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import subprocess
import sys
import threading
import time
from collections import deque
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

#: The heartbeat's period, s (the thruster supervisor sends one a tick; 0.4 s trips).
PERIOD_S = 0.01
#: Structures the load builds per round (every 5 ms).
BATCH = 2000


def _heartbeat(stop: threading.Event, lateness: list[float]) -> None:
    deadline = time.perf_counter() + PERIOD_S
    while not stop.is_set():
        time.sleep(max(0.0, deadline - time.perf_counter()))
        lateness.append(max(0.0, time.perf_counter() - deadline))
        deadline += PERIOD_S
        if deadline < time.perf_counter():  # a long pause: the next beat from now
            deadline = time.perf_counter() + PERIOD_S


def _load(stop: threading.Event, heap: int) -> None:
    """Request-like structures living ~1-2 s (some cyclic), about ``heap`` of them alive at
    any time: they outlive the young collections, so full ones fall due (a loaded service:
    jobs, cached runs, stream clients)."""
    alive: deque[list[dict[str, Any]]] = deque()
    while not stop.is_set():
        batch = []
        for i in range(BATCH):
            item: dict[str, Any] = {"seq": i, "values": [float(i)] * 4, "tags": ["a", "b"]}
            if i % 10 == 0:
                item["self"] = item  # a cycle: only the collector frees it
            batch.append(item)
        alive.append(batch)
        while len(alive) * BATCH > heap:
            alive.popleft()
        time.sleep(0.005)


async def _child(mode: str, seconds: float, heap: int) -> dict[str, Any]:
    import gc
    import tempfile

    import api.http.app  # noqa: F401 - what a service process holds
    import estimation.axis.tow_estimate  # noqa: F401
    from daq import collector
    from daq import session as session_module
    from daq.session import RigSession, RigSource
    from daq.store import Store

    if mode == "plain":  # the session arms without holding full collections off
        session_module.hold_full_collections = lambda *held: None  # type: ignore[assignment]
    full: list[float] = []
    young = 0
    started: dict[str, float] = {}

    def timed(phase: str, info: dict[str, Any]) -> None:
        nonlocal young
        if phase == "start":
            started["t"] = time.perf_counter()
        elif info["generation"] == 2:
            full.append(time.perf_counter() - started["t"])
        else:
            young += 1

    sys.setswitchinterval(0.0005)  # as RigService serves (api.core.service)
    with tempfile.TemporaryDirectory() as tmp:
        store = Store(f"sqlite:///{tmp}/bench.db", spill_dir=Path(tmp) / "spill")
        async with RigSession(RigSource.load(), store) as session:
            if mode == "guarded":
                collector.freeze_after_startup()
            await session.arm_thrusters()
            rss_armed = _rss_mb()
            stop = threading.Event()
            lateness: list[float] = []
            gc.callbacks.append(timed)
            threads = [
                threading.Thread(target=_heartbeat, args=(stop, lateness)),
                threading.Thread(target=_load, args=(stop, heap)),
            ]
            for thread in threads:
                thread.start()
            await asyncio.sleep(seconds)
            stop.set()
            for thread in threads:
                thread.join()
            gc.callbacks.remove(timed)
            rss_grown = _rss_mb() - rss_armed
            await session.disarm_thrusters()
        store.close()
    lateness.sort()
    return {
        "heartbeat_max_late_s": round(lateness[-1], 4),
        "heartbeat_p99_late_s": round(lateness[int(0.99 * (len(lateness) - 1))], 4),
        "beats": len(lateness),
        "full_collections_while_armed": len(full),
        "longest_full_collection_s": round(max(full), 4) if full else 0.0,
        "young_collections": young,
        "frozen_objects": gc.get_freeze_count(),
        "rss_growth_while_armed_mb": round(rss_grown, 1),
    }


def _rss_mb() -> float:
    """Resident memory of this process now, MB (Linux /proc)."""
    with open("/proc/self/statm", encoding="ascii") as f:
        pages = int(f.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="armed time per mode, s")
    parser.add_argument("--heap", type=int, default=300_000, help="objects built per round")
    parser.add_argument("--child", choices=("plain", "guarded"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(asyncio.run(_child(args.child, args.seconds, args.heap))))
        return
    out: dict[str, Any] = {"bench": "gc_pause", "seconds": args.seconds, "heap": args.heap}
    for mode in ("plain", "guarded"):
        command = [sys.executable, __file__, "--child", mode, "--seconds", str(args.seconds)]
        done = subprocess.run(
            [*command, "--heap", str(args.heap)], capture_output=True, text=True, cwd=ROOT
        )
        if done.returncode != 0:
            raise SystemExit(f"{mode}: {done.stderr.strip().splitlines()[-1:]}")
        out[mode] = json.loads(done.stdout.strip().splitlines()[-1])
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
