"""Waiting for a ``rig serve`` subprocess to answer, and stopping it."""

from __future__ import annotations

import subprocess
import threading
from collections.abc import Callable

import httpx

from tests.support.waiting import read_until, wait_until

SERVICE_LINE = "rig service: http://127.0.0.1:"


def wait_for_service(proc: subprocess.Popen, timeout_s: float = 30.0) -> str:
    """The base URL ``rig serve`` printed, once its /api/health answers ok.

    Its output is drained by a thread for the process's whole life (a pipe nobody reads
    fills at 64 KiB and then blocks the service on its next log line), so a warning printed
    before the address line, or a silent service, fails here after ``timeout_s`` with the
    output so far instead of blocking on a read.
    """
    lines: list[str] = []

    def drain() -> None:
        for line in proc.stdout:
            lines.append(line)

    threading.Thread(target=drain, daemon=True).start()

    def address() -> str | None:
        found = [ln for ln in lines if ln.startswith(SERVICE_LINE)]
        if found:
            return found[0].split()[2]
        assert proc.poll() is None, "rig serve exited:\n" + "".join(lines)
        return None

    url = read_until(address, bool, "rig serve printing its address", timeout_s=timeout_s)
    wait_healthy(proc, url, lambda: "".join(lines), timeout_s=timeout_s)
    return url


def wait_healthy(
    proc: subprocess.Popen, url: str, output: Callable[[], str], timeout_s: float = 30.0
) -> None:
    """Until ``url``/api/health answers ok (uvicorn listens just after ``rig serve`` prints
    its lines: there is no event to wait on). Fails with ``output()`` if the process exits."""

    def healthy() -> bool:
        try:
            if httpx.get(url + "api/health", timeout=1).json()["ok"]:
                return True
        except httpx.HTTPError:
            pass
        assert proc.poll() is None, f"rig serve exited: {output()}"
        return False

    wait_until(healthy, "rig serve answering /api/health", timeout_s=timeout_s, poll_s=0.1)


def stop_service(proc: subprocess.Popen) -> None:
    """SIGTERM (the rig is left safe by the service's lifespan), SIGKILL after 15 s."""
    proc.terminate()
    try:
        proc.wait(15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
