"""Where the test suite's wall time goes: the README's test command, timed (issue 34 item 5).

Runs ``python -m pytest -m ""`` (pyproject's addopts: the workers and their scheduling) with
this module as a plugin, which appends one line per test to a timeline file (worker, node
id, start and end in wall seconds, the worker's own CPU over the test), while the runner
samples the CPU of every process under pytest once a second from ``/proc`` (a process's
user + system time as last seen, by kind: xdist worker, chromium, ``rig serve``, spawned
analysis or upload child, …; a process that lives under a second can be missed). Prints one
JSON document:

* ``wall_s``, ``outcome`` (pytest's last line);
* ``cpu_s``: the run's user + system as ``os.times`` counts it, children included — only the
  processes waited for down the tree: a process whose parent ended first (a killed
  ``rig serve``'s workers, a browser's helpers) is reaped by init and not in it;
  ``processes_cpu_s``: the sum over every process seen under pytest (each counted once,
  keyed by pid and start time); ``machine_cpu_s``: every core's busy time over the run
  (``/proc/stat``), which on a quiet machine is the suite's whole CPU;
* ``first_test_s``: when the first test began (the session's start-up: byte code, numba's
  cache, the workers' imports and collection);
* ``workers``: each worker's busy seconds and when its last test ended — the spread between
  the first and the last worker to finish is what scheduling can still win;
* ``last_modules``: the modules that ended last (on the critical path);
* ``modules``: the longest modules (summed test wall seconds, worker CPU, tests);
* ``cpu_by_kind``: CPU seconds per process kind, ``processes_by_kind`` how many processes of
  each kind were seen (a forkserver's children run its command line: a child is told from
  its server by its parent), ``children_cpu_s`` each such child's CPU; ``tests_by_cpu``: the
  tests whose worker spent the most CPU.

Wall seconds on this 2-core machine depend on what else runs: compare runs by alternating
them, and read ``cpu_s`` beside ``wall_s``.

    .venv/bin/python bench/suite_time.py [--out /tmp/suite] [PYTEST ARGS …]
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
TIMELINE_ENV = "SUITE_TIME_TIMELINE"
TICKS = os.sysconf("SC_CLK_TCK")
#: The kind of an analysis worker's or a CSV upload's process (spawned, or forked from a server).
CHILD = "spawned child (analysis worker, CSV upload)"

# --- the plugin (loaded in the controller and every worker by ``-p bench.suite_time``) ---


@pytest.hookimpl(wrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: pytest.Item | None) -> Any:
    path = os.environ.get(TIMELINE_ENV)
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    start, cpu = time.time(), time.process_time()
    result = yield
    if path:
        line = {"worker": worker, "id": item.nodeid, "start": start, "end": time.time()}
        line["cpu"] = time.process_time() - cpu
        with open(path, "a", encoding="utf-8") as out:  # one short append per test
            out.write(json.dumps(line) + "\n")
    return result


# --- the runner ---


def _kind(cmdline: str, parent: str = "") -> str:
    """The kind of the process running ``cmdline``, whose parent runs ``parent``."""
    if "multiprocessing.forkserver" in cmdline:  # a forked child runs its server's command
        if "multiprocessing.forkserver" in parent:
            return CHILD
        return "forkserver (preloaded: the children's imports)"
    if "chromium" in cmdline:
        return "chromium"
    if "playwright" in cmdline:
        return "playwright driver"
    if "postgres" in cmdline:
        return "postgres"
    if "spawn_main" in cmdline:
        return CHILD
    if "exec(eval(sys.stdin" in cmdline:
        return "xdist worker"
    # before "pytest": a service or command a test starts has pytest's tmp paths in its args
    if "api.cli.serve" in cmdline or "rig serve" in cmdline:
        return "rig serve"
    if "api.cli" in cmdline or "/rig " in cmdline:
        return "rig command"
    if "pytest" in cmdline:
        return "pytest controller"
    if "mypy" in cmdline:
        return "mypy"
    return cmdline.split(" ")[0].rsplit("/", 1)[-1] or "?"


def _processes() -> dict[int, tuple[int, float, str, int]]:
    """pid -> (parent pid, user + system CPU s, command line, start time in clock ticks
    since boot) of every process now (a zombie's command line is empty)."""
    found = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            stat = Path(entry.path, "stat").read_text()
            cmdline = Path(entry.path, "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        cpu = (int(fields[11]) + int(fields[12])) / TICKS
        found[int(entry.name)] = (int(fields[1]), cpu, cmdline.strip(), int(fields[19]))
    return found


def _machine_busy_s() -> float:
    """CPU seconds every core of the machine has spent busy since boot (``/proc/stat``:
    user, nice, system, irq, softirq and steal)."""
    fields = Path("/proc/stat").read_text().splitlines()[0].split()[1:]
    user, nice, system, _idle, _iowait, irq, softirq, steal = map(int, fields[:8])
    return (user + nice + system + irq + softirq + steal) / TICKS


def _sample(root: int, seen: dict[tuple[int, int], tuple[str, float]]) -> None:
    """Record the kind and CPU of every process under ``root``, keyed by (pid, start time):
    one entry per process however often it is seen, after an ``exec`` (its kind is its new
    command's) and as a zombie (kind kept, CPU final)."""
    procs = _processes()
    children = collections.defaultdict(list)
    for pid, (parent, _, _, _) in procs.items():
        children[parent].append(pid)
    stack = [root]
    while stack:
        pid = stack.pop()
        stack.extend(children.get(pid, ()))
        if pid in procs:
            parent, cpu, cmdline, started = procs[pid]
            key = (pid, started)
            parent_cmdline = procs[parent][2] if parent in procs else ""
            fresh = cmdline or key not in seen
            seen[key] = (_kind(cmdline, parent_cmdline) if fresh else seen[key][0], cpu)


def _summary(timeline: list[dict[str, Any]], t0: float) -> dict[str, Any]:
    """Times in seconds from the command's start (``t0``, wall)."""
    modules: dict[str, dict[str, Any]] = {}
    workers: dict[str, dict[str, float]] = {}
    for line in timeline:
        name = line["id"].split("::", 1)[0]
        wall = line["end"] - line["start"]
        m = modules.setdefault(name, {"wall_s": 0.0, "cpu_s": 0.0, "tests": 0, "end_s": 0.0})
        m["wall_s"] += wall
        m["cpu_s"] += line["cpu"]
        m["tests"] += 1
        m["end_s"] = max(m["end_s"], line["end"] - t0)
        m["worker"] = line["worker"]
        w = workers.setdefault(line["worker"], {"busy_s": 0.0, "last_end_s": 0.0})
        w["busy_s"] += wall
        w["last_end_s"] = max(w["last_end_s"], line["end"] - t0)

    def rounded(d: dict[str, Any]) -> dict[str, Any]:
        return {k: round(v, 1) if isinstance(v, float) else v for k, v in d.items()}

    longest = sorted(modules.items(), key=lambda kv: -kv[1]["wall_s"])[:25]
    last = sorted(modules.items(), key=lambda kv: -kv[1]["end_s"])[:8]
    by_cpu = sorted(timeline, key=lambda line: -line["cpu"])[:20]
    return {
        "first_test_s": round(min(line["start"] for line in timeline) - t0, 1),
        "workers": {w: rounded(v) for w, v in sorted(workers.items())},
        "last_modules": {n: rounded(m) for n, m in last},
        "modules": {n: rounded(m) for n, m in longest},
        "tests_by_cpu": {line["id"]: round(line["cpu"], 1) for line in by_cpu},
        "tests_worker_cpu_s": round(sum(line["cpu"] for line in timeline), 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("/tmp/suite-time"))
    args, pytest_args = parser.parse_known_args()
    args.out.mkdir(parents=True, exist_ok=True)
    timeline = args.out / "timeline.jsonl"
    timeline.unlink(missing_ok=True)
    command = [sys.executable, "-m", "pytest", "-m", "", "-p", "bench.suite_time", *pytest_args]
    env = os.environ | {TIMELINE_ENV: str(timeline)}
    before, started, t0 = os.times(), time.monotonic(), time.time()
    with open(args.out / "pytest.txt", "w", encoding="utf-8") as log:
        run = subprocess.Popen(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
        seen: dict[tuple[int, int], tuple[str, float]] = {}
        busy_before = _machine_busy_s()
        while run.poll() is None:
            _sample(run.pid, seen)
            time.sleep(1.0)
    wall, after = time.monotonic() - started, os.times()
    machine_cpu = _machine_busy_s() - busy_before
    cpu = (after.children_user - before.children_user) + (
        after.children_system - before.children_system
    )
    by_kind: dict[str, float] = collections.Counter()
    count: dict[str, int] = collections.Counter()
    for kind, seconds in seen.values():
        by_kind[kind] += seconds
        count[kind] += 1
    text = (args.out / "pytest.txt").read_text(encoding="utf-8").strip().splitlines()
    lines = [json.loads(line) for line in timeline.read_text(encoding="utf-8").splitlines()]
    report = {
        "command": " ".join(command[1:]),
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "machine_cpu_s": round(machine_cpu, 1),
        "processes_cpu_s": round(sum(s for _, s in seen.values()), 1),
        "outcome": re.sub(r"=+", "", text[-1]).strip() if text else "",
        "failed": [line for line in text if line.startswith(("FAILED", "ERROR"))],
        "cpu_by_kind": {k: round(v, 1) for k, v in sorted(by_kind.items(), key=lambda kv: -kv[1])},
        "processes_by_kind": dict(sorted(count.items(), key=lambda kv: -kv[1])),
        "children_cpu_s": sorted((round(s, 2) for k, s in seen.values() if k == CHILD))[::-1],
    } | _summary(lines, t0)
    print(json.dumps(report, indent=1, ensure_ascii=False))


if __name__ == "__main__":
    main()
