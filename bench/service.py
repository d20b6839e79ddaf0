"""The rig service as ``rig serve`` runs it, in a thread of the benchmark's process."""

from __future__ import annotations

import socket
import threading
import time


def serve_in_thread(db_url: str, token: str, realtime: bool, start_timeout_s: float = 60.0):
    """Start the simulated rig's service on a free loopback port.

    Returns (service, app, server, thread, base URL); stop with ``server.should_exit``.
    """
    import uvicorn

    from api.core.service import RigService
    from api.http.app import create_app
    from daq.session import RigSource

    service = RigService(RigSource.load(), db_url, realtime=realtime)
    app = create_app(service, token=token)
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(
        uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on")
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    end = time.monotonic() + start_timeout_s
    while not server.started:  # uvicorn offers no event to wait on
        if time.monotonic() > end:
            raise SystemExit("uvicorn did not start")
        time.sleep(0.05)
    return service, app, server, thread, f"http://127.0.0.1:{sock.getsockname()[1]}"


def wait_job(http, job_id: str, states: tuple[str, ...], timeout_s: float = 60) -> dict:
    """Poll ``/api/jobs/{job_id}`` (an httpx client) until its state is one of ``states``."""
    end = time.monotonic() + timeout_s
    while True:
        job = http.get(f"/api/jobs/{job_id}").json()
        if job["state"] in states:
            return job
        if time.monotonic() > end:
            raise SystemExit(f"job {job_id} stuck in {job['state']}")
        time.sleep(0.1)
