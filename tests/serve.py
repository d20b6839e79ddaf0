"""Waiting for a ``rig serve`` subprocess to answer, and stopping it."""

from __future__ import annotations

import subprocess
from collections.abc import Callable

import httpx

from tests.waiting import wait_until


def wait_for_service(proc: subprocess.Popen, timeout_s: float = 30.0) -> str:
    """The base URL ``rig serve`` printed, once its /api/health answers ok.

    Fails with the process output when it exits first or stays silent past ``timeout_s``.
    """
    first = proc.stdout.readline()
    assert first.startswith("rig service: http://127.0.0.1:"), first + proc.stdout.read()
    url = first.split()[2]
    wait_healthy(proc, url, proc.stdout.read, timeout_s=timeout_s)
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
