"""Fixtures of the API tests: one simulated rig behind the app, a real uvicorn server."""

from __future__ import annotations

import asyncio
import contextlib
import functools
import socket
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any, ClassVar

import httpx
import pytest
import uvicorn
from fastapi.testclient import TestClient

from api.core.service import RigService
from api.http.app import create_app
from daq.session import RigSource
from daq.sim.inprocess import open_inprocess_rig
from daq.sim.simtime import SimTimeLoop
from tests.conftest import require_tool
from tests.support.waiting import read_until, wait_until

TOKEN = "test-token-123"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
FINAL = ("completed", "aborted", "failed")
#: A short tow: the whole job takes about 3 s on the simulated rig.
SHORT_TOW = {"force_n": 24.5, "max_time_s": 1.5, "baseline_s": 0.3}


def wait_job(client, job_id: str, *, states=FINAL, timeout_s: float = 30.0) -> dict:
    """Poll the job until its state is one of ``states``."""
    return read_until(
        lambda: client.get(f"/api/jobs/{job_id}", headers=AUTH).json(),
        lambda job: job["state"] in states,
        f"job {job_id} in one of {states}",
        timeout_s=timeout_s,
        poll_s=0.05,
    )


def how_it_ended(job: dict) -> str:
    """A job's id, state and why, for an assertion on how it ended: its error, outcome (its
    first 400 characters) and last progress; pytest cuts a whole job's dict before them."""
    outcome = repr(job.get("outcome"))
    outcome = outcome if len(outcome) <= 400 else outcome[:400] + "…"
    return (
        f"job {job.get('id')} {job.get('state')}: error {job.get('error')!r}, "
        f"outcome {outcome}, progress {job.get('progress')!r}"
    )


def completed_estimation(client, run_ids, *, timeout_s: float = 120.0, **fields) -> dict:
    """``POST /api/jobs/estimation`` of ``run_ids`` (no effect search, unless ``fields`` say
    otherwise) and the job once completed (fails naming the job if it did not complete)."""
    body = {"run_ids": run_ids, "search_effects": False} | fields
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=timeout_s)
    assert job["state"] == "completed", how_it_ended(job)
    return job


def wait_job_until(
    client, job_id: str, ready: Callable[[dict], bool], what: str, *, timeout_s: float = 30.0
) -> dict:
    """Poll the job until ``ready(job)``; fails naming ``what`` if the job ends first."""

    def ready_or_ended(job: dict) -> bool:
        if ready(job):
            return True
        assert job["state"] not in FINAL, f"job {job_id} ended {job['state']} before {what}: {job}"
        return False

    return read_until(
        lambda: client.get(f"/api/jobs/{job_id}", headers=AUTH).json(),
        ready_or_ended,
        f"job {job_id}: {what}",
        timeout_s=timeout_s,
        poll_s=0.05,
    )


def moving_for(seconds: float) -> Callable[[dict], bool]:
    """``ready`` for a tow/spin job whose axis has moved for ``seconds``, read from the
    procedure's progress message (``tow: 0.123 m in 0.8 s``)."""

    def ready(job: dict) -> bool:
        message = (job.get("progress") or {}).get("message", "")
        if not message.startswith(("tow:", "spin:")) or " in " not in message:
            return False
        return float(message.rsplit(" in ", 1)[1].split()[0]) >= seconds

    return ready


def wait_rig_free(client, timeout_s: float = 30.0) -> None:
    """Wait until no job holds the rig (e.g. one a previous test aborted is winding down)."""
    read_until(
        lambda: client.get("/api/rig", headers=AUTH).json()["current_job"],
        lambda job: job is None,
        "the rig free of jobs",
        timeout_s=timeout_s,
        poll_s=0.05,
    )


def start_job(client, path: str, body: dict) -> str:
    """Start a job once the rig is free; returns its id."""
    wait_rig_free(client)
    r = client.post(path, json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    return r.json()["id"]


#: How much faster than the wall clock a ``simtime`` module's rig may run while it waits for
#: HTTP requests (``SimTimeLoop(pace=...)``): a 3 s tow in 0.3 s. An idle rig still steps its
#: plant (and holds the GIL) that much more often than in real time, so a module that
#: seldom runs a test is faster left in real time.
SERVICE_PACE = 10.0
#: The pace while no job holds the rig: an idle rig only serves HTTP requests and streams
#: samples, and at ``SERVICE_PACE`` its ticks cost about 0.05 s of CPU per wall second.
IDLE_SERVICE_PACE = 1.0


@pytest.fixture(scope="module")
def service(request: pytest.FixtureRequest, tmp_path_factory) -> Iterator[RigService]:
    """The rig service of the module, defined here once: in a ``simtime`` module the simulated
    rig in process on simulated time (paced: ``SERVICE_PACE``), otherwise over Modbus TCP and
    a pty in real time, with the reply allowances of a loaded test machine
    (``tests.procedures.conftest.simulated_rig_file``). A module's ``rig_service`` marker
    builds it, always in process on simulated time, from ``rig`` (a rig file, or
    ``"fast-pendulum"``: the fast pendulum's, ``tests.procedures.test_pendulum.fast_rig_file``),
    ``scenario`` (a scenario file) and ``spill`` (True: a spill folder of its own,
    ``RIG_SPILL_DIR``)."""
    folder = tmp_path_factory.mktemp("api")
    db = f"sqlite:///{folder / 'rig.db'}"
    marker = request.node.get_closest_marker("rig_service")
    if marker is None:
        if request.node.get_closest_marker("simtime") is None:
            from tests.procedures.conftest import simulated_rig_file

            yield RigService(RigSource.load(simulated_rig_file(folder)), db)
        else:
            yield simulated_service(RigSource.load(), db)
        return
    rig = marker.kwargs.get("rig")
    if rig == "fast-pendulum":
        from tests.procedures.test_pendulum import fast_rig_file

        rig = fast_rig_file(folder)
    source = RigSource.load(rig, scenario_file=marker.kwargs.get("scenario"))
    with pytest.MonkeyPatch.context() as patch:
        if marker.kwargs.get("spill"):
            patch.setenv("RIG_SPILL_DIR", str(folder / "spill"))
        yield simulated_service(source, db)


def simulated_service(source: RigSource, store_url: str, **options: Any) -> RigService:
    """A rig service (not started) whose rig thread runs the simulated rig in process on
    simulated time, paced at ``SERVICE_PACE`` while a job holds the rig and at
    ``IDLE_SERVICE_PACE`` otherwise; ``options`` as for ``RigService``."""

    def rig_held() -> bool:
        session = service.session
        return session is not None and session.lock_holder is not None

    service = RigService(
        source,
        store_url,
        loop_factory=functools.partial(
            SimTimeLoop, pace=SERVICE_PACE, idle_pace=IDLE_SERVICE_PACE, busy=rig_held
        ),
        devices=open_inprocess_rig,
        **options,
    )
    return service


@pytest.fixture(scope="module")
def imports_in_a_thread() -> Iterator[None]:
    """The module's CSV uploads imported in a worker thread, not a child process
    (``api.core.csv_upload``: a process per upload, forked from the preloaded server). For
    modules where the import is incidental; the child's path is tested by
    test_import_kinds_api.py, test_edge_limits.py and the browser tests."""
    from api.core import csv_upload

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(csv_upload, "shared_by_processes", lambda url: False)
        yield


@pytest.fixture(scope="module")
def client(service: RigService, tmp_path_factory) -> Iterator[TestClient]:
    app = create_app(
        service,
        token=TOKEN,
        max_upload_bytes=64 * 1024,
        report_root=tmp_path_factory.mktemp("reports"),
    )
    # the module's page server (``page_server``) stops before the service does
    with TestClient(app) as c, contextlib.ExitStack() as page_servers:
        app.state.page_servers = page_servers
        yield c


@pytest.fixture(scope="module")
def tow_job(client: TestClient) -> dict:
    """One completed short tow (shared by the read tests)."""
    job = wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))
    assert job["state"] == "completed", how_it_ended(job)
    return job


def estimate_in_page(page, runs: list[str], timeout_ms: int) -> None:
    """On the Estimation page (the live stream kept out: these tests are not about it),
    select ``runs``, start the estimation and wait for it to complete."""
    from playwright.sync_api import expect

    page.route("**/api/stream**", lambda route: route.abort())
    page.click("nav a[data-page=estimation]")
    for run in runs:
        page.check(f"#est-runs input[value='{run}']")
    page.click("#est-run")
    expect(page.locator("#est-state")).to_have_text("completed", timeout=timeout_ms)


class LiveServer:
    """A real uvicorn server in a thread on a free loopback port."""

    def __init__(self, app) -> None:
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        self.server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="off"))
        self.thread = threading.Thread(target=self.server.run, kwargs={"sockets": [self.sock]})

    def __enter__(self) -> LiveServer:
        self.thread.start()
        # uvicorn sets a flag, not an event, once it serves
        wait_until(lambda: self.server.started, "uvicorn started", timeout_s=10)
        return self

    def __exit__(self, *exc: object) -> None:
        self.server.should_exit = True
        self.thread.join(10)
        self.sock.close()


@pytest.fixture(scope="module")
def live_url(service: RigService, client: TestClient):
    """The same rig service and jobs behind a second app served by real uvicorn (streams)."""
    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, httpx.Client(base_url=live.url, headers=AUTH, timeout=10) as h:
        yield h


#: How long a page's action or assertion waits for the page (ms): an event, never a sleep;
#: it only ends a test whose page never gets there.
PAGE_TIMEOUT_MS = 30_000


class Chromium:
    """One real headless Debian Chromium (never a downloaded browser), driven by Playwright's
    sync API, for every browser test of a session (an xdist worker): launching it took about
    1.5 s a test. Each test gets a fresh context (no cookies, storage or cache of another
    test) and page from ``page()``.

    Between its calls Playwright's sync API leaves its own event loop marked as the thread's
    running loop (playwright/_impl/_greenlets.py ``wait_for_future``), so an ``asyncio.run``
    or a pytest-asyncio test after it on the same worker would fail with "cannot be called
    from a running event loop". The mark is put back for the duration of ``page()`` and
    cleared outside it.
    """

    ARGS: ClassVar[list[str]] = [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-background-networking",
    ]

    def __init__(self, executable: str) -> None:
        from playwright.sync_api import expect, sync_playwright

        # An assertion on the page waits as long as an action does: Playwright's 5 s default
        # for ``expect`` was shorter than a page's answer beside a busy process (a queue
        # edit's form still open after 5 s, in a fresh-clone run beside one busy loop).
        expect.set_options(timeout=PAGE_TIMEOUT_MS)
        self._playwright = sync_playwright().start()
        self._loop = asyncio._get_running_loop()  # Playwright's, marked running
        try:
            self._browser = self._playwright.chromium.launch(
                executable_path=executable, args=self.ARGS
            )
        except BaseException:
            self._playwright.stop()  # no driver left behind a browser that did not start
            raise
        finally:
            asyncio._set_running_loop(None)

    @contextlib.contextmanager
    def page(self) -> Iterator[Any]:
        """A page in a new browser context, closed after the ``with`` block; the page's
        Content-Security-Policy violations are recorded (``csp_blocked``)."""
        outside = asyncio._get_running_loop()
        asyncio._set_running_loop(self._loop)
        try:
            context = self._browser.new_context()
            try:
                page = context.new_page()
                page.set_default_timeout(PAGE_TIMEOUT_MS)
                page.add_init_script(CSP_WATCH)
                yield page
            finally:
                context.close()
        finally:
            asyncio._set_running_loop(outside)

    def close(self) -> None:
        asyncio._set_running_loop(self._loop)
        try:
            self._browser.close()
        finally:
            self._playwright.stop()  # runs Playwright's loop to its end and closes it
            asyncio._set_running_loop(None)


@pytest.fixture(scope="session")
def chromium() -> Iterator[Chromium]:
    """The session's headless Chromium (``Chromium``): skips on a laptop without
    ``chromium``, fails under ``CI=true``."""
    executable = require_tool("chromium", "the browser UI is tested in real headless Chromium")
    browser = Chromium(executable)
    try:
        yield browser
    finally:
        browser.close()


@contextlib.contextmanager
def signed_in_page(chromium: Chromium, service: RigService, client: TestClient) -> Iterator[Any]:
    """``client``'s rig service and jobs behind a real uvicorn server (``page_server``), and
    a page of the session's ``chromium`` on it (a fresh browser context), signed in with the
    test token."""
    with contextlib.ExitStack() as own:
        live = page_server(service, client, own)
        with chromium.page() as page:
            page.goto(f"{live.url}/#token={TOKEN}")
            yield page
            assert csp_blocked(page) == []  # the page's Content-Security-Policy blocked nothing


def page_server(service: RigService, client: TestClient, own: contextlib.ExitStack) -> LiveServer:
    """The real uvicorn server of ``client``'s rig service and jobs that pages open: one per
    module (the ``client`` fixture's, stopped with it), or for a client a test made itself one
    entered on ``own``. A server and app per page cost each test about half a second of the
    worker's CPU: the app's first request builds every route's models (FastAPI does that
    lazily, per app), and uvicorn's start and stop."""
    state = client.app.state
    live: LiveServer | None = getattr(state, "page_server", None)
    if live is not None:
        return live
    app = create_app(service, token=TOKEN, manage_service=False, runner=state.runner)
    shared: contextlib.ExitStack | None = getattr(state, "page_servers", None)
    live = (shared or own).enter_context(LiveServer(app))
    if shared is not None:
        state.page_server = live
    return live


#: Records what the page's Content-Security-Policy blocks (``csp_blocked``).
CSP_WATCH = (
    "window.cspBlocked = []; document.addEventListener('securitypolicyviolation', "
    "(e) => window.cspBlocked.push(`${e.violatedDirective} ${e.blockedURI}`));"
)


def csp_blocked(page: Any) -> list[str]:
    """What the Content-Security-Policy blocked on ``page`` since it loaded."""
    return page.evaluate("() => window.cspBlocked")


def completed_tows(client, forces: Iterable[float], body: dict = SHORT_TOW) -> list[str]:
    """One tow job per force (the rest of the request ``body``), each run to completion;
    their run ids in order."""
    runs = []
    for force in forces:
        job = wait_job(client, start_job(client, "/api/jobs/tow", body | {"force_n": force}))
        assert job["state"] == "completed", how_it_ended(job)
        runs += job["run_ids"]
    return runs
