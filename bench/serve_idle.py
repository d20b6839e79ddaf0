"""The memory of an idle ``rig serve``, as a user starts it (issue 33: idle ≤ 150 MB).

Each run starts ``rig serve --port 0`` on the simulated rig (the default rig file and
scenario; the token from ``$RIG_API_TOKEN``, the database and the address file in a fresh
``$XDG_DATA_HOME``) as a process of its own on the checkout ``--src`` (default: this one;
another, e.g. a worktree of the base commit, to compare), waits until ``/api/health``
answers, then until it is idle: its background warm-up of the estimator's kernels has ended
and its processes (the service and every descendant: the fork server, the analysis worker,
``multiprocessing``'s resource tracker, whichever the checkout starts) have stayed the same
for ``--settle`` seconds. It then reads each one's ``/proc/PID/smaps_rollup`` and prints,
per process (by role) and in total, the proportional set size (PSS: shared pages divided
among the processes mapping them, so the total is what the processes cost the machine
together) and the resident set size (RSS: each process's pages, shared ones counted in every
process), MB; and the CPU seconds every process spent until then. SIGINT ends the service
(as Ctrl-C does). With ``--tow`` it first records one short tow through the API (what a
first test starts: the analysis worker's fork server) and measures once that has ended.

Each checkout is byte-compiled and run once untimed first (numba's cache filled), as an
install leaves it. ``--repeat`` runs the checkouts alternately (base, ours, base, …); prints
one JSON document with each run and each figure's median per checkout, and ours over base
where two are given.

    .venv/bin/python bench/serve_idle.py [--repeat 3] [--settle 2] [--tow] [--src DIR ...]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the service runs in processes of its own, on --src

from bench.checkouts import alternated  # noqa: E402

TICKS = os.sysconf("SC_CLK_TCK")
TOKEN = "bench-serve-idle-token"
FINAL = ("completed", "aborted", "failed", "interrupted")


def _stat(pid: int) -> list[str]:
    """The fields of ``/proc/PID/stat`` after the command name (state first)."""
    return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()


def _cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` so far."""
    fields = _stat(pid)
    return (int(fields[11]) + int(fields[12])) / TICKS


def _descendants(root: int) -> list[int]:
    """``root`` and every living descendant of it (by parent pid)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = _stat(int(entry.name))
        except (FileNotFoundError, ProcessLookupError):
            continue
        if fields[0] != "Z":
            children.setdefault(int(fields[1]), []).append(int(entry.name))
    found, todo = [], [root]
    while todo:
        pid = todo.pop()
        found.append(pid)
        todo.extend(children.get(pid, []))
    return sorted(found)


def _cmdline(pid: int) -> str:
    return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()


def _role(pid: int, service: int) -> str:
    """What process ``pid`` of the service's tree is, by its command line and parent."""
    if pid == service:
        return "service"
    line = _cmdline(pid)
    if "compiled_warm_up" in line:
        return "warm_up"
    if "resource_tracker" in line:
        return "resource_tracker"
    if "forkserver" in line:  # the server, and each child forked from it (same command line)
        return "forkserver" if int(_stat(pid)[1]) == service else "worker"
    return "other"


def _memory_mb(pid: int) -> dict[str, float]:
    """RSS and PSS of process ``pid`` (MB)."""
    found = {}
    for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
        key, _, value = line.partition(":")
        if key in ("Rss", "Pss"):
            found[key.lower()] = int(value.split()[0]) / 1024
    return found


def _answers(url: str) -> bool:
    import urllib.error
    import urllib.request

    try:
        with urllib.request.urlopen(f"{url}/api/health", timeout=2) as reply:
            return bool(reply.status == 200)
    except (urllib.error.URLError, ConnectionError, TimeoutError):
        return False


def _api(url: str, path: str, body: dict[str, Any] | None = None) -> dict[str, Any]:
    """GET (or POST ``body`` to) ``path`` with the token; the JSON reply."""
    import urllib.request

    data = None if body is None else json.dumps(body).encode()
    headers = {"Authorization": f"Bearer {TOKEN}", "Content-Type": "application/json"}
    request = urllib.request.Request(f"{url}{path}", data=data, headers=headers)
    with urllib.request.urlopen(request, timeout=30) as reply:
        return dict(json.loads(reply.read()))


def _tow(url: str, timeout_s: float = 120.0) -> None:
    """One short tow through the API, waited for until it ends."""
    job = _api(url, "/api/jobs/tow", {"force_n": 24.5, "max_time_s": 1.5, "baseline_s": 0.3})
    end = time.monotonic() + timeout_s
    while (state := _api(url, f"/api/jobs/{job['id']}")["state"]) not in FINAL:
        if time.monotonic() > end:
            raise SystemExit(f"the tow did not end: {state}")
        time.sleep(0.2)  # the job offers no event to wait on from outside
    if state != "completed":
        raise SystemExit(f"the tow ended {state}")


def _run(src: Path, settle_s: float, tow: bool, timeout_s: float = 180.0) -> dict[str, Any]:
    """One ``rig serve`` on the checkout ``src``, measured once idle, then ended."""
    with tempfile.TemporaryDirectory(prefix="serve-idle-") as folder:
        env = os.environ | {
            "PYTHONPATH": str(src),
            "XDG_DATA_HOME": folder,
            "RIG_API_TOKEN": TOKEN,
        }
        env.pop("RIG_DATABASE_URL", None)
        env.pop("RIG_ANALYSIS_WORKERS", None)
        started = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, "-m", "api.cli.main", "serve", "--port", "0"],
            cwd=src,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert proc.stdout is not None
            url = None
            for line in proc.stdout:  # the first line says where it listens
                if found := re.search(r"rig service: (http://\S+?)/? ", line):
                    url = found.group(1)
                    break
            if url is None:
                raise SystemExit(f"{src}: rig serve said no address: {proc.stderr.read()}")
            end = time.monotonic() + timeout_s
            while not _answers(url):  # a server offers no event to wait on from outside
                if time.monotonic() > end or proc.poll() is not None:
                    raise SystemExit(f"{src}: rig serve did not answer")
                time.sleep(0.05)
            answered = time.perf_counter() - started
            if tow:
                _tow(url)
            # idle: no warm-up left and the same processes for settle_s
            stable_since, seen = time.monotonic(), _descendants(proc.pid)
            while True:
                time.sleep(0.2)
                now = _descendants(proc.pid)
                roles = [_role(pid, proc.pid) for pid in now]
                if now != seen or "warm_up" in roles:
                    stable_since, seen = time.monotonic(), now
                elif time.monotonic() - stable_since >= settle_s:
                    break
                if time.monotonic() > end:
                    raise SystemExit(f"{src}: rig serve did not settle: {roles}")
            processes: dict[str, dict[str, float]] = {}
            cpu_s = 0.0
            for pid in seen:
                role = _role(pid, proc.pid)
                memory = _memory_mb(pid)
                cpu_s += _cpu_s(pid)
                into = processes.setdefault(role, {"count": 0, "rss": 0.0, "pss": 0.0})
                into["count"] += 1
                into["rss"] += memory["rss"]
                into["pss"] += memory["pss"]
        finally:
            proc.send_signal(signal.SIGINT)  # Ctrl-C: the service leaves the rig safe
            try:
                proc.communicate(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()
    rounded = {
        role: {k: round(v, 1) for k, v in figures.items()} for role, figures in processes.items()
    }
    return {
        "answered_s": round(answered, 3),
        "total_pss_mb": round(sum(p["pss"] for p in processes.values()), 1),
        "total_rss_mb": round(sum(p["rss"] for p in processes.values()), 1),
        "service_rss_mb": rounded["service"]["rss"],
        "cpu_s": round(cpu_s, 3),
        "processes": rounded,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--settle", type=float, default=2.0, help="seconds without change")
    parser.add_argument("--tow", action="store_true", help="measure after one short tow")
    parser.add_argument("--src", type=Path, action="append", help="a checkout (repeatable)")
    args = parser.parse_args()
    sources = [src.resolve() for src in args.src or [ROOT]]
    found = alternated(sources, lambda src: _run(src, args.settle, args.tow), args.repeat)
    doc: dict[str, Any] = {"repeat": args.repeat, "tow": args.tow} | found
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
