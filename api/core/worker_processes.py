"""How the service starts the processes it hands CPU work to: forked from a server that
imported their code once.

The analysis worker (``api.core.analysis_executor``) and each CSV upload's import
(``api.core.csv_upload``) run in child processes of their own, never beside the clock's
thread. A spawned child is a new interpreter: each one imported NumPy, SciPy, the store and
the fits again (~0.7 s of CPU before its first task, ``bench/worker_start.py``), and the
service starts one per CSV upload and a new worker after each killed fit. Here each is
forked from a server process instead (``multiprocessing``'s ``forkserver``, its public API
only): a fresh interpreter started once, which imports ``PRELOAD`` and then only forks; a
child begins with that code imported, in milliseconds.

The server is a process of its own, started with ``exec`` like a spawned child: the
service's threaded process is never forked. It inherits the scheduling of the thread that
starts it, and the service's threads may run real-time: so :func:`worker_context` starts it
from a short-lived thread at normal scheduling and ``SERVER_NICENESS`` (its imports yield to
the rig as a spawned worker's did); each child still sets its own priority. A child starts
with the service's environment as it is when the child starts (:class:`_Process`), not the
server's, as a spawned child did. The server starts with the service's first test
(``AnalysisWorker.prepare``: its ~0.7 s of CPU overlap the test) or its first child, if that
comes first (an analysis or a CSV upload, which then waits for those imports), not with the
service: it holds the preloaded modules, ~85 MB resident (~65 MB proportional with no worker
beside it, and ~7 MB more for ``multiprocessing``'s resource tracker it starts), which an
idle service does not need (``bench/serve_idle.py``). It ends once the service and all its
children have ended (``multiprocessing.forkserver``).

The server is the process's one ``forkserver`` (``multiprocessing`` has one per process):
whoever starts it first decides what it preloads. The service is the only user in a rig's
process; a test module that starts it first with another preload (``tests/store``) leaves
the children correct, only slower to start.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from multiprocessing import forkserver
from typing import Any

from daq.priority import lower_priority

#: What the server imports before its first fork: the analysis worker's code (the fits, the
#: cross-check and the campaign's fit with their report figures) and the CSV import's, and
#: ``scipy.special``, whose statistics every fit's tests and budgets call (those modules
#: import it where it is called, as the service imports them too and never loads SciPy).
PRELOAD = (
    "api.core.analysis_executor",
    "api.core.estimation_job",
    "api.core.crosscheck_job",
    "api.core.campaign_fit",
    "api.core.csv_upload",
    "scipy.special",
)

#: Niceness of the server: that of the analysis worker (``ANALYSIS_NICENESS``). Not above
#: any child's: a child inherits it and may raise its niceness (a CSV import's 10), never
#: lower it.
SERVER_NICENESS = 5

_FORKSERVER = multiprocessing.get_context("forkserver")


class _Process(_FORKSERVER.Process):  # type: ignore[name-defined,misc]
    """A child of the server that runs with the environment of the process that started
    it, as at its start (the server's is the service's when the server started)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.environ = dict(os.environ)

    def run(self) -> None:
        os.environ.clear()
        os.environ.update(self.environ)
        super().run()


class _Context(type(_FORKSERVER)):  # type: ignore[misc]
    """The ``forkserver`` context whose processes are :class:`_Process`."""

    Process = _Process


_CONTEXT = _Context()
_START = threading.Lock()


def _start_server() -> None:
    """In a thread of its own: drop to normal scheduling at ``SERVER_NICENESS`` (this
    thread only), then start the server, which inherits them."""
    lower_priority(SERVER_NICENESS)
    _CONTEXT.set_forkserver_preload(list(PRELOAD))
    forkserver.ensure_running()


def worker_context() -> multiprocessing.context.BaseContext:
    """The ``multiprocessing`` context whose processes fork from the preloaded server (for
    ``mp_context`` of a ``ProcessPoolExecutor``), the server started if need be."""
    with _START:
        starter = threading.Thread(target=_start_server, name="forkserver-start")
        starter.start()
        starter.join()
    return _CONTEXT
