"""Waiting for a ``rig serve`` subprocess to answer, and stopping it."""

from __future__ import annotations

import subprocess
import time

import httpx


def wait_for_service(proc: subprocess.Popen, timeout_s: float = 30.0) -> str:
    """The base URL ``rig serve`` printed, once its /api/health answers ok.

    Fails with the process output when it exits first or stays silent past ``timeout_s``.
    """
    first = proc.stdout.readline()
    assert first.startswith("rig service: http://127.0.0.1:"), first + proc.stdout.read()
    url = first.split()[2]
    end = time.monotonic() + timeout_s
    while True:
        try:
            if httpx.get(url + "api/health", timeout=1).json()["ok"]:
                return url
        except httpx.HTTPError:
            pass
        assert proc.poll() is None, f"rig serve exited: {proc.stdout.read()}"
        assert time.monotonic() < end, "rig serve did not come up"
        time.sleep(0.1)  # polling a server that is starting: there is no event to wait on


def stop_service(proc: subprocess.Popen) -> None:
    """SIGTERM (the rig is left safe by the service's lifespan), SIGKILL after 15 s."""
    proc.terminate()
    try:
        proc.wait(15)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
