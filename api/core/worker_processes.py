"""How the service starts the processes it hands CPU work to: forked from a server that
imported their code once.

The analysis worker (``api.core.analysis_executor``) and each CSV upload's import
(``api.core.csv_upload``) run in child processes of their own, never beside the clock's
thread. A spawned child is a new interpreter: each one imported NumPy, SciPy, the store and
the fits again (~0.7 s of CPU before its first task), and the service starts one per CSV
upload and a new worker after each killed fit. Here each is forked from one server process
instead (``multiprocessing``'s ``forkserver``): a fresh interpreter started once, at the
first child, which imports ``PRELOAD`` and then only forks; a child begins with that code
imported, in milliseconds.

The server is a process of its own, started with ``exec`` like a spawned child: the
service's threaded process is never forked. It is this module's own server, not
``multiprocessing``'s process-wide one (another user of that, with its own preload, would
decide what ours imported). It runs at ``SERVER_NICENESS`` (its imports yield to the rig
as a spawned worker's did), and each child still sets its own priority. A child starts with
the service's environment as it is when the child starts (:class:`_Process`), not the
server's, as a spawned child did. The server ends once the service and all its children have
ended (``multiprocessing.forkserver``); while the service lives it holds the preloaded
modules, ~85 MB resident, most of it shared with the worker forked from it (~35 MB
proportional set size; ``bench/worker_start.py``).
"""

from __future__ import annotations

import contextlib
import io
import multiprocessing.context
import os
from multiprocessing import forkserver, popen_forkserver, reduction, spawn, util
from typing import Any

#: What the server imports before its first fork: the analysis worker's code (the fits, the
#: cross-check and the campaign's fit with their report figures) and the CSV import's.
PRELOAD = (
    "api.core.analysis_executor",
    "api.core.estimation_job",
    "api.core.crosscheck_job",
    "api.core.campaign_fit",
    "api.core.csv_upload",
)

#: Niceness of the server: that of the analysis worker (``ANALYSIS_NICENESS``). Not above
#: any child's: a child inherits it and may raise its niceness (a CSV import's 10), never
#: lower it.
SERVER_NICENESS = 5


class _Server(forkserver.ForkServer):
    """A fork server importing ``preload``, at ``niceness`` once started."""

    def __init__(self, preload: tuple[str, ...], niceness: int) -> None:
        super().__init__()
        self.set_forkserver_preload(list(preload))
        self.niceness = niceness
        self._niced: int | None = None

    def ensure_running(self) -> None:
        super().ensure_running()
        pid = self.pid
        if pid is not None and pid != self._niced:
            _lower_priority(pid, self.niceness)
            self._niced = pid

    @property
    def pid(self) -> int | None:
        """The server's process id (None before the first child)."""
        return self._forkserver_pid  # type: ignore[attr-defined,no-any-return]


def _lower_priority(pid: int, niceness: int) -> None:
    """Process ``pid`` (the server) at normal scheduling and ``niceness``, whatever it
    inherited from the thread that started it (``daq.priority.lower_priority``)."""
    with contextlib.suppress(OSError):
        if os.sched_getscheduler(pid) != os.SCHED_OTHER:
            os.sched_setscheduler(pid, os.SCHED_OTHER, os.sched_param(0))
        os.setpriority(os.PRIO_PROCESS, pid, niceness)


_SERVER = _Server(PRELOAD, SERVER_NICENESS)


class _Popen(popen_forkserver.Popen):
    """``multiprocessing``'s forkserver launch (``popen_forkserver.Popen._launch``, the
    same steps) asking ``_SERVER`` for the child instead of the process-wide server."""

    def _launch(self, process_obj: Any) -> None:
        prep_data = spawn.get_preparation_data(process_obj.name)
        buf = io.BytesIO()
        multiprocessing.context.set_spawning_popen(self)
        try:
            reduction.dump(prep_data, buf)
            reduction.dump(process_obj, buf)
        finally:
            multiprocessing.context.set_spawning_popen(None)
        self.sentinel, w = _SERVER.connect_to_new_process(self._fds)  # type: ignore[attr-defined]
        # the child watches a duplicate of the data pipe's write end: it ends with us
        parent_w = os.dup(w)
        self.finalizer = util.Finalize(self, _close_fds, (parent_w, self.sentinel))
        with open(w, "wb", closefd=True) as f:
            f.write(buf.getbuffer())
        self.pid = forkserver.read_signed(self.sentinel)


def _close_fds(*fds: int) -> None:
    for fd in fds:
        os.close(fd)


class _Process(multiprocessing.context.ForkServerProcess):
    """A child of ``_SERVER`` that runs with the environment of the process that started
    it, as at its start (the server's is the service's when the server started)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.environ = dict(os.environ)

    @staticmethod
    def _Popen(process_obj: Any) -> _Popen:
        return _Popen(process_obj)

    def run(self) -> None:
        os.environ.clear()
        os.environ.update(self.environ)
        super().run()


class _Context(multiprocessing.context.ForkServerContext):
    Process = _Process  # type: ignore[assignment]


_CONTEXT = _Context()


def worker_context() -> multiprocessing.context.BaseContext:
    """The ``multiprocessing`` context whose processes fork from the preloaded server (for
    ``mp_context`` of a ``ProcessPoolExecutor``)."""
    return _CONTEXT


def server_pid() -> int | None:
    """The server's process id, None until the first child started it."""
    return _SERVER.pid
