"""Shared test configuration.

Tests that need an outside program (mbpoll, chromium, a PostgreSQL server) call
``require_tool`` or use ``postgres_server``: on a developer's laptop they skip when it is
missing, but with ``CI=true`` they fail, so CI can never go green by skipping them.

``db_url`` gives a fresh, empty database on each backend: SQLite, and PostgreSQL from
``$RIG_TEST_POSTGRES_URL`` if set, else a throwaway cluster started from the installed
server binaries (tests/support/pg.py). ``head_db_url`` gives one already migrated to the newest
revision, copied from a database migrated once per session (SQLite's backup, PostgreSQL's
``CREATE DATABASE … TEMPLATE``): for tests of what a store does, not of how it is made
(running every migration again costs 0.1-0.2 s a test).

Lanes and workers (pyproject.toml): ``pytest`` runs the fast lane (``-m 'not slow'``) on
three xdist workers; ``pytest -m ""`` runs everything (CI). Tests are scheduled by module
(``--dist loadscope``), so module-scoped fixtures (recorded runs, servers) are built once.

Simulated time: a test or module marked ``simtime`` runs its async fixtures and tests on
``daq.sim.simtime.SimTimeLoop`` (``pytest_asyncio_loop_factories`` below), where
``tests/support/simrig.py`` and the API's ``service`` fixture put the simulated rig in process. The
few modules that prove the real stack (Modbus TCP/RTU, the thruster pty, ``rig``
subprocesses, the browser, the fault proxies) run in real time.
"""

from __future__ import annotations

import asyncio
import contextlib
import fcntl
import os
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from daq.sim.simtime import SimTimeLoop
from tests.support.pg import PostgresServer, external_postgres, find_postgres_bin, start_postgres
from tests.support.waiting import set_test_budget

if TYPE_CHECKING:
    from daq.store import Store

IN_CI = os.environ.get("CI", "").lower() == "true"


def pytest_configure(config: pytest.Config) -> None:
    """The service's ignored warnings (``api.http.known_warnings``) are the suite's too, so a
    new warning stands out in its summary."""
    from api.http.known_warnings import PYTEST_FILTER

    config.addinivalue_line("filterwarnings", PYTEST_FILTER)


@pytest.hookimpl
def pytest_asyncio_loop_factories(config: pytest.Config, item: pytest.Item) -> dict:
    """Tests marked ``simtime`` run on simulated time (``daq.sim.simtime.SimTimeLoop``):
    their async fixtures and the test share one loop whose clock jumps when all wait."""
    if item.get_closest_marker("simtime") is not None:
        return {"simtime": SimTimeLoop}
    return {"asyncio": asyncio.new_event_loop}


@pytest.hookimpl(tryfirst=True)
def pytest_sessionstart(session: pytest.Session) -> None:
    """The xdist controller byte-compiles the checkout, then starts compiling the estimator's
    RK4 loop into numba's cache (``estimation.motion.compiled_warm_up``) in a process of its
    own, before it starts the workers (xdist's own ``pytest_sessionstart`` is ``trylast``).
    On a fresh clone the cache is empty, and every worker, analysis worker and ``rig serve``
    warm-up that integrates before the first compile is written compiled it again: three cold
    workers at once took 58 s of CPU, one compile then two cache loads 22 s. The compile
    (~15 s of one core on a fresh clone; ~1 s from a warm cache) runs while the workers
    import and collect, on the core the controller alone would leave idle; each worker waits
    for it before its first test (``pytest_runtestloop``)."""
    config = session.config
    if hasattr(config, "workerinput"):
        return  # a worker: the controller did both before it started
    _byte_compile_the_checkout()
    if not getattr(config.option, "numprocesses", None):
        return  # one process (-n 0): it compiles numba's loop at most once anyway
    config.stash[_WARM_UP] = _CompiledWarmUp.start(Path(tempfile.mkdtemp(prefix="warm-up-")))


def _byte_compile_the_checkout() -> None:
    """Write the checkout's byte code once, as an install does: a machine that sets
    ``PYTHONDONTWRITEBYTECODE`` (this one does) would otherwise compile every module from
    source in every process the suite starts — each ``rig`` command, ``rig serve``, xdist
    worker, analysis worker and CSV parse: about 0.7 s of CPU for the service's and the
    estimator's imports (3.7 s from source, 2.9 s from byte code). Unchanged files are
    skipped."""
    import compileall

    root = Path(__file__).resolve().parents[1]
    for package in ("api", "daq", "estimation", "thrusters", "tests"):
        compileall.compile_dir(root / package, quiet=1, workers=1)


class _CompiledWarmUp:
    """numba's compile of the RK4 loop in a process of its own, whose end the workers wait
    for: the process holds an exclusive ``flock`` on ``lock`` from before it starts (the
    controller hands it the locked file) to its exit, however it ends; a worker's shared lock
    is granted once it has ended (an event, no polling). Its output goes to ``log``."""

    #: The environment variable that tells the workers the lock file's path.
    ENV = "TOWRIG_TEST_WARM_UP_LOCK"
    #: How long a worker waits for the compile before it goes on without it (s): then its
    #: first integration compiles the loop itself, slower but correct.
    WAIT_S = 600.0

    def __init__(self, process: subprocess.Popen, log: Path) -> None:
        self.process, self.log = process, log
        self.late_workers: list[str] = []  # a worker's report of a wait it gave up

    @classmethod
    def start(cls, folder: Path) -> _CompiledWarmUp:
        lock, log = folder / "lock", folder / "output.txt"
        fd = os.open(lock, os.O_CREAT | os.O_RDWR, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
            with open(log, "wb") as out:
                process = subprocess.Popen(
                    [sys.executable, "-c", _WARM_UP_CODE],
                    stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                    pass_fds=(fd,),
                )  # fmt: skip
        finally:
            os.close(fd)  # the process holds the lock now, until it exits
        os.environ[cls.ENV] = str(lock)  # the workers, started after this, inherit it
        return cls(process, log)

    @classmethod
    def wait(cls) -> str | None:
        """In a worker: wait until the compile has ended; None, or why it did not wait."""
        path = os.environ.get(cls.ENV)
        if not path:
            return None
        fd = os.open(path, os.O_RDONLY)
        granted = threading.Thread(target=fcntl.flock, args=(fd, fcntl.LOCK_SH), daemon=True)
        granted.start()
        granted.join(cls.WAIT_S)
        if granted.is_alive():
            return f"numba's warm-up still held {path} after {cls.WAIT_S:.0f} s"
        os.close(fd)
        return None

    def outcome(self) -> str | None:
        """In the controller, at the end: None, or how the warm-up failed; its files go."""
        code = self.process.wait()
        output = self.log.read_text(encoding="utf-8", errors="replace")
        shutil.rmtree(self.log.parent, ignore_errors=True)
        return None if code == 0 else f"numba's warm-up exited with {code}:\n{output}"


#: The warm-up's program: compile the loop into numba's cache (or load it from there).
_WARM_UP_CODE = "from estimation.motion.compiled_warm_up import warm_up; warm_up()"
_WARM_UP = pytest.StashKey[_CompiledWarmUp]()


@pytest.hookimpl(tryfirst=True)
def pytest_runtestloop(session: pytest.Session) -> None:
    """A worker waits for the controller's numba warm-up (``_CompiledWarmUp``) after it has
    collected and before its first test; a wait that gave up is reported to the controller
    (xdist's ``workeroutput``)."""
    config = session.config
    if hasattr(config, "workerinput") and (late := _CompiledWarmUp.wait()):
        config.workeroutput[_CompiledWarmUp.ENV] = late  # type: ignore[attr-defined]


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node: Any, error: object) -> None:
    """The controller keeps a worker's report of a warm-up it gave up waiting for."""
    warm_up = node.config.stash.get(_WARM_UP, None)
    late = getattr(node, "workeroutput", {}).get(_CompiledWarmUp.ENV)
    if warm_up is not None and late:
        warm_up.late_workers.append(f"{node.gateway.id}: {late}")


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    """The controller says when its numba warm-up failed or a worker gave up waiting for it
    (the workers then compiled the loop on their first integration: slower, still correct; a
    broken loop fails the estimator's tests themselves)."""
    warm_up = config.stash.get(_WARM_UP, None)
    if warm_up is None:
        return
    for problem in filter(None, [warm_up.outcome(), *warm_up.late_workers]):
        terminalreporter.write_sep("=", "numba warm-up", red=True)
        terminalreporter.write_line(problem)


@pytest.hookimpl(wrapper=True)
def pytest_collection(session: pytest.Session) -> Iterator[object]:
    """While the test modules are collected, pytest writes their assert-rewritten byte code
    (``__pycache__/*-pytest-*.pyc``), as it does by default: with ``PYTHONDONTWRITEBYTECODE``
    set (this machine) it never did, and every worker of every run rewrote and compiled the
    228 test modules and conftests again before its first test: ``pytest --collect-only
    -m ""`` took 11.0 s of CPU, 6.1 s with the cache (means of three alternating runs).
    The cache is checked against the source (mtime, size) and written atomically (workers
    collect at once). Only for the collection: the processes the tests start keep the
    setting (``_byte_compile_the_checkout`` writes the checkout's own byte code)."""
    writes_no_bytecode = sys.dont_write_bytecode
    sys.dont_write_bytecode = False
    try:
        return (yield)
    finally:
        sys.dont_write_bytecode = writes_no_bytecode


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """A test on a browser page (the ``chromium`` fixture, tests/api/conftest.py) is in the
    slow lane wherever it is written: a page is the real stack in real time. ``tryfirst``:
    marked before ``-m`` deselects. Then the modules are put in the order the workers take
    them (`_longest_first`)."""
    for item in items:
        if "chromium" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.slow)
    items[:] = _longest_first(items)


def _longest_first(items: list[pytest.Item]) -> list[pytest.Item]:
    """``items`` by module, the modules likely to take longest first, each module's tests in
    their own order. xdist's ``loadscope`` hands the workers whole modules in this order
    (``--no-loadscope-reorder`` in pyproject.toml; its own reorder puts the modules with the
    most tests first, which left single long tests, the browser pages, mypy, schemathesis,
    to start last and run on alone at the end). Longest-first list scheduling leaves the
    shortest tail; "longest" is guessed from the tests marked slow (the real stack,
    statistical fits), most first, then the others by their number. On the durations of
    one full run, simulated on three workers: the last worker ends 28 s sooner (668 s
    against 696 s), 5 s after the 663 s of ordering by the measured durations themselves.
    Full runs did not show it (11:19-12:19 against 11:45 with xdist's order): the gain
    is within their spread."""
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        modules.setdefault(item.nodeid.split("::", 1)[0], []).append(item)

    def expected(tests: list[pytest.Item]) -> tuple[int, int]:
        return sum(t.get_closest_marker("slow") is not None for t in tests), len(tests)

    ordered = sorted(modules.values(), key=expected, reverse=True)
    return [item for tests in ordered for item in tests]


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_timeout_set_timer(item: pytest.Item, settings: Any) -> None:
    """As pytest-timeout starts a test's timer (``settings.timeout`` s), every wait of the
    test is told when it fires, to give up before it naming what it waited for
    (``tests.support.waiting.set_test_budget``); pytest-timeout's own hook then sets it."""
    set_test_budget(time.monotonic() + settings.timeout, settings.timeout)


@pytest.hookimpl(tryfirst=True, optionalhook=True)
def pytest_timeout_cancel_timer(item: pytest.Item) -> None:
    """The test's timer is cancelled: no budget until the next one starts."""
    set_test_budget(None)


def require_tool(name: str, why: str) -> str:
    """Path of the executable ``name``; skip (or fail under CI=true) when missing."""
    path = shutil.which(name)
    if path:
        return path
    message = f"{name} not found: {why}"
    if IN_CI:
        pytest.fail(message + " (required when CI=true)")
    pytest.skip(message)
    raise AssertionError("unreachable")


BACKENDS = ["sqlite", "postgresql"]


@pytest.fixture(scope="session")
def postgres_server() -> Iterator[PostgresServer]:
    """One PostgreSQL server for the whole session."""
    url = os.environ.get("RIG_TEST_POSTGRES_URL", "").strip()
    if url:
        server = external_postgres(url)
    elif find_postgres_bin() is not None:
        server = start_postgres()
    else:
        message = "no PostgreSQL: set RIG_TEST_POSTGRES_URL or install postgresql (initdb)"
        if IN_CI:
            pytest.fail(message + " (required when CI=true)")
        pytest.skip(message)
    try:
        yield server
    finally:
        server.stop()


@contextlib.contextmanager
def fresh_database(
    backend: str, request: pytest.FixtureRequest, folder: Path, name: str = "rig.db"
) -> Iterator[str]:
    """URL of a fresh, empty database on ``backend``: SQLite at ``folder/name``, or a new
    database on the session's PostgreSQL server, dropped after."""
    if backend == "sqlite":
        yield f"sqlite:///{folder / name}"
        return
    server: PostgresServer = request.getfixturevalue("postgres_server")
    url = server.create_database()
    try:
        yield url
    finally:
        server.drop_database(url)


@pytest.fixture(params=BACKENDS)
def db_url(request: pytest.FixtureRequest, tmp_path) -> Iterator[str]:
    """URL of a fresh, empty database on each backend."""
    with fresh_database(request.param, request, tmp_path) as url:
        yield url


@pytest.fixture(scope="session")
def sqlite_head_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An SQLite database migrated to head, once for the session (copy it, never open it)."""
    from daq.store import Store

    path = tmp_path_factory.mktemp("head") / "rig.db"
    Store(f"sqlite:///{path}").close()
    return path


def copy_sqlite(source: Path, path: Path) -> str:
    """URL of a new SQLite database at ``path``, a copy of ``source`` (SQLite's backup: what
    is still in its write-ahead log is copied too)."""
    original, copy = sqlite3.connect(source), sqlite3.connect(path)
    try:
        original.backup(copy)
    finally:
        original.close()
        copy.close()
    return f"sqlite:///{path}"


@pytest.fixture
def store_backend() -> str:
    """The backend of ``store``: SQLite, except in folders whose conftest parametrises it
    over ``BACKENDS`` (tests/store: what a store does holds on both)."""
    return "sqlite"


@pytest.fixture
def head_db_url(
    request: pytest.FixtureRequest, store_backend: str, tmp_path: Path
) -> Iterator[str]:
    """URL of a fresh database already migrated to head on ``store_backend``."""
    if store_backend == "sqlite":
        yield copy_sqlite(request.getfixturevalue("sqlite_head_template"), tmp_path / "rig.db")
        return
    server: PostgresServer = request.getfixturevalue("postgres_server")
    url = server.create_database(at_head=True)
    try:
        yield url
    finally:
        server.drop_database(url)


@pytest.fixture
def store(head_db_url: str) -> Iterator[Store]:
    """An open Store on a fresh database at head (``head_db_url``), closed after the test."""
    from daq.store import Store

    with Store(head_db_url) as opened:
        yield opened
