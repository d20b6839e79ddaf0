"""Where an analysis job's fit runs: the seam between the job registry and the fitting.

An analysis (an estimation, a cross-check) is an :class:`AnalysisTask` (what to fit, the
database it reads and stores into, where to draw its report); running it gives an
:class:`AnalysisOutcome` (the result document and id, or the error), which
:class:`api.core.analysis_worker.AnalysisWorker` writes into the job registry.
:func:`run_analysis` is the one function that turns a task into its outcome; an
:class:`AnalysisExecutor` says where it runs:

* :class:`ProcessExecutor` (the service's): in a worker process at niceness
  ``ANALYSIS_NICENESS``, so a fit (170 MB, seconds of CPU, full garbage collections) never
  shares the GIL, the memory or the CPU priority of the rig's process. One per process
  (:func:`shared_process_executor`), started by its first task (or :meth:`ProcessExecutor.start`;
  an idle service holds none) and kept while the process lives. The worker is forked from a
  server that imported the fitting and report modules once (``api.core.worker_processes``;
  the service starts it with its first test, :meth:`ProcessExecutor.prepare`): it is ready
  in milliseconds where a spawned interpreter spent ~0.7 s of CPU importing them, and so is
  the worker that replaces a killed one;
* :class:`ThreadExecutor`: in the calling thread, on the service's own ``Store`` (a database
  no other process can open: in-memory SQLite; and tests that patch the fit in process).

* :class:`api.core.cluster_executor.DaskExecutor` (``rig serve --analysis-workers``): on a
  Dask distributed cluster's workers, other machines that can open the database at
  ``store_url`` (docs/api.md, "Analysis workers").
"""

from __future__ import annotations

import atexit
import concurrent.futures
import contextlib
import functools
import io
import itertools
import multiprocessing
import os
import pickle
import signal
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol, TypeVar

from api.core.worker_processes import worker_context
from daq.priority import lower_priority
from daq.store import Store
from daq.store.migrate import shared_by_processes

#: Niceness of the analysis worker process: the rig's process and the clock come first. Not
#: 10: beside three processes at normal priority (a test run's workers, a busy host) a fit at
#: 10 gets ~4 % of the machine and a 10 s fit takes minutes; the clock does not share the
#: worker's GIL, and in real-time mode no niceness can delay it.
ANALYSIS_NICENESS = 5

#: How long (s) the worker process may take over one task before it is taken as hung: it is
#: then killed and replaced, and the task fails saying so. Every analysis here takes seconds
#: (ship2d's estimate, the largest record shipped, ~7 s of CPU); without a bound one hung fit
#: would hold the one-at-a-time queue, every job after it and the service's shutdown.
ANALYSIS_DEADLINE_S = 1800.0

#: What an analysis task fits: an estimation job, a cross-check job, or a campaign's fit of
#: one axis after its run (``api.core.campaign_fit``; its outcome's ``data["fit"]`` is the
#: ``AxisFit``).
T = TypeVar("T")

AnalysisKind = Literal["estimation", "crosscheck", "campaign_fit"]


@dataclass(frozen=True)
class AnalysisTask:
    """One analysis to run: ``kind`` with ``params`` (the keyword arguments of
    ``run_estimation``, ``crosscheck_runs`` or ``fit_campaign_axis`` besides the store and
    the report folder),
    on the database at ``store_url``, its report figures drawn into ``report_dir``."""

    kind: AnalysisKind
    params: dict[str, Any]
    store_url: str
    report_dir: Path


@dataclass(frozen=True)
class AnalysisOutcome:
    """How an analysis ended: ``data`` (the result document, scratch paths included) and
    ``result_id`` with the closing ``message``, or ``error`` (one line; ``bad_input`` for a
    ValueError/KeyError naming a field, else ``traceback`` for the log; ``stopped``: ended by
    its :class:`TaskStop`, ``error`` the reason). ``reports`` are the (result id, folder)
    pairs whose figures belong to a stored result; ``pid`` and ``niceness`` say where it
    ran."""

    data: dict[str, Any] | None
    result_id: int | None
    message: str
    pid: int
    niceness: int
    error: str | None = None
    bad_input: bool = False
    traceback: str | None = None
    reports: tuple[tuple[int, Path], ...] = field(default=())
    stopped: bool = False


class TaskStop:
    """A request to stop one task before its end (its job aborted): ``reason`` once
    :meth:`request` was called. The executor running the task binds (:meth:`bind`) what stops it
    there; an executor that cannot stop a task says why in its ``cannot_stop``."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.reason: str | None = None
        self._act: Callable[[], object] | None = None

    def request(self, reason: str) -> None:
        """Stop the task for ``reason`` (the first reason given stays)."""
        with self._lock:
            self.reason = self.reason or reason
            act = self._act
        if act is not None:
            act()

    def bind(self, act: Callable[[], object] | None) -> None:
        """``act`` stops the task from now on (None: the task ended); called at once if a stop
        was already requested."""
        with self._lock:
            self._act = act
            asked = self.reason is not None
        if asked and act is not None:
            act()


class AnalysisExecutor(Protocol):
    """Runs analysis tasks somewhere and hands back their outcomes."""

    #: Why this executor cannot stop a task once it began (one line), None if ``stop`` can.
    cannot_stop: str | None

    def run(self, task: AnalysisTask, stop: TaskStop | None = None) -> AnalysisOutcome:
        """Run ``task`` to its end (blocks the calling thread); never raises for a failed fit.
        ``stop``, requested, ends it early as a ``stopped`` outcome where the executor can."""
        ...

    def call(self, store_url: str | None, fn: Callable[..., T], /, *args: Any) -> T:
        """``fn(store, *args)`` where analyses run, on the database at ``store_url``
        (``fn(*args)`` for None): its value, or its exception raised here (``portable``).
        For the work a route answers at once but that costs CPU (an export, a sensitivity
        study, a 6-DOF simulation, a cross-check's figure): ``fn`` is a module-level
        function (or a ``partial`` of one), its arguments and value plain data."""
        ...

    def close(self) -> None:
        """Wait for the task running, release the workers."""
        ...


def _fit(task: AnalysisTask, store: Store) -> AnalysisOutcome:
    folder = task.report_dir
    pid, niceness = os.getpid(), os.getpriority(os.PRIO_PROCESS, 0)
    reports: tuple[tuple[int, Path], ...] = ()
    if task.kind == "estimation":
        from api.core.estimation_job import run_estimation

        data = run_estimation(store, report_dir=folder, **task.params)
        result_id = data.get("result_id")
        if result_id is not None:
            reports = ((result_id, folder),)
        return AnalysisOutcome(data, result_id, "estimation done", pid, niceness, reports=reports)
    if task.kind == "campaign_fit":
        from api.core.campaign_fit import fit_campaign_axis

        fit = fit_campaign_axis(store, **task.params)
        return AnalysisOutcome({"fit": fit}, fit.result_id, "fitted", pid, niceness)
    from api.core.crosscheck_job import crosscheck_runs

    data = crosscheck_runs(store, report_dir=folder, **task.params)
    sides = (("weight_estimation", "weight"), ("thruster_estimation", "thrusters"))
    reports = ((data["result_id"], folder),)
    reports += tuple((data[key]["result_id"], folder / side) for key, side in sides)
    message = f"cross-check done: {data['verdict']}"
    return AnalysisOutcome(data, data["result_id"], message, pid, niceness, reports=reports)


def run_analysis(task: AnalysisTask, store: Store | None = None) -> AnalysisOutcome:
    """Run ``task`` on ``store`` (default: a ``Store`` opened on ``task.store_url`` and
    closed after); a failure is an outcome with its error, never an exception."""
    own = store is None
    try:
        db = Store(task.store_url) if store is None else store
        try:
            return _fit(task, db)
        finally:
            if own:
                db.close()
    except Exception as err:
        error = f"internal error: {type(err).__name__}: {err}" if is_defect(err) else str(err)
        return AnalysisOutcome(
            None,
            None,
            f"error: {error}",
            pid=os.getpid(),
            niceness=os.getpriority(os.PRIO_PROCESS, 0),
            error=error,
            bad_input=isinstance(err, ValueError | KeyError) and not is_defect(err),
            traceback=traceback.format_exc(),
        )


#: The built-in errors that only a defect of ours raises on checked input: a lookup, an
#: attribute, a type or an assertion the code did not expect. Bad input that is a missing
#: thing raises a subclass naming it (``RunNotFound``, ``ResultNotFound``: KeyError), so a
#: bare ``KeyError`` is not bad input: a job ended ``failed`` with ``error`` "<RunKind.PENDULUM:
#: 'pendulum'>", unlogged, when a merge asked the thrust calibration about a pendulum.
DEFECTS = (KeyError, IndexError, AttributeError, TypeError, NameError, AssertionError)


def is_defect(err: BaseException) -> bool:
    """Whether ``err`` is one of ``DEFECTS`` exactly (not a subclass that names bad input)."""
    return type(err) in DEFECTS


def portable(err: Exception) -> Exception:
    """``err`` as it can cross a process boundary: itself, alone (its cause, context and
    traceback dropped), when it survives plain pickling, else the nearest built-in class
    with its one line (a ``ValueError`` naming a field stays a ``ValueError``, so the faces
    answer it as bad input).

    Plain pickling, whatever the process has installed: once ``dask`` is imported (xarray
    imports it for a NetCDF export when the cluster extra is installed) tblib pickles
    exceptions with their whole chain, and a class in that chain that the receiving side
    cannot rebuild broke the worker pool (a rehearsal's BrokenProcessPool)."""
    err.__cause__ = err.__context__ = err.__traceback__ = None
    try:
        buffer = io.BytesIO()
        pickler = pickle.Pickler(buffer)
        pickler.dispatch_table = {}  # each class's own reduce, not copyreg's (tblib's)
        pickler.dump(err)
        pickle.loads(buffer.getvalue())
        return err
    except Exception:
        base = next(c for c in (ValueError, KeyError, OSError, RuntimeError, Exception)
                    if isinstance(err, c))  # fmt: skip
        return base(str(err))


def call_on_store(store_url: str | None, fn: Callable[..., T], args: tuple[Any, ...]) -> T:
    """``fn(store, *args)`` on a ``Store`` opened on ``store_url`` (closed after), or
    ``fn(*args)`` for None: what a worker process runs for :meth:`AnalysisExecutor.call`."""
    try:
        if store_url is None:
            return fn(*args)
        with Store(store_url) as store:
            return fn(store, *args)
    except Exception as err:
        failure = portable(err)
    raise failure  # outside the handler, so nothing is chained to it


def _exit_with_parent() -> None:
    """End this worker once the process that started it (the service) is gone: a service
    killed with SIGKILL (or out of memory) cannot shut its pool down, and its idle worker
    (85-385 MB) would live on, and with it the server it was forked from. Waits on
    ``multiprocessing``'s sentinel of the parent (a pipe the parent holds open while it
    lives); the worker's own parent process is that server, not the service."""
    parent = multiprocessing.parent_process()
    if parent is not None:
        parent.join()
    os.kill(os.getpid(), signal.SIGTERM)  # the default action: the process ends


#: In a worker process: its ``_Worker.state`` (the parent's shared array).
_STATE: Any = None


def _start_worker(state: Any) -> None:
    """The worker process's start: keep ``state`` (``_Worker.state``), watch the process
    that started it, lower its priority, and have what every analysis runs (the fits, the
    report's figures) imported, so no task waits for it (the server preloaded them:
    ``worker_processes.PRELOAD``; here they are found in ``sys.modules``)."""
    global _STATE
    _STATE = state
    threading.Thread(target=_exit_with_parent, name="parent-watch", daemon=True).start()
    lower_priority(ANALYSIS_NICENESS)
    import api.core.campaign_fit
    import api.core.crosscheck_job
    import api.core.estimation_job  # noqa: F401


def _numbered(number: int, fn: Callable[..., T], *args: Any) -> T:
    """In the worker process: ``fn(*args)`` as task ``number`` (``_Worker.state``), or
    :class:`_Skipped` if that task was stopped before it began."""
    with _STATE.get_lock():
        if _STATE[1] == number:
            raise _Skipped(number)
        _STATE[0] = number
    return fn(*args)


class _Skipped(Exception):
    """The worker skipped a task stopped before it began (its number the message)."""


@dataclass
class _Worker:
    """One worker process: its pool, its pid (a future: the worker imports first), and
    ``state``, an array shared with it: [the number of the task it began last, the number
    of a task to skip]; its lock orders a task's start against a kill (``_end``)."""

    pool: concurrent.futures.ProcessPoolExecutor
    pid: concurrent.futures.Future[int]
    state: Any
    #: The number of the task it ran when this executor killed it (None: not killed).
    killed: int | None = None


class ProcessExecutor:
    """One worker process (forked from ``worker_processes``' preloaded server) at niceness
    ``ANALYSIS_NICENESS``, started by
    :meth:`start` or the first task and kept for the next ones (its imports and compiled
    fits stay warm). A worker that dies (killed, out of memory) fails its task with one
    line and is replaced; so does one still busy with a task after ``deadline_s`` (s, default
    ``ANALYSIS_DEADLINE_S``), which is killed first, and one running a task whose
    :class:`TaskStop` was requested (the task ends ``stopped``). A task that waited behind
    a killed one is run again on the new worker."""

    #: It can: its worker process is killed.
    cannot_stop: str | None = None

    def __init__(self, deadline_s: float = ANALYSIS_DEADLINE_S) -> None:
        self._current: _Worker | None = None
        self._lock = threading.Lock()
        self._numbers = itertools.count(1)
        self.deadline_s = float(deadline_s)
        #: (pid, niceness) of the worker process that ran the last task.
        self.worker: tuple[int, int] | None = None

    def _worker(self) -> _Worker:
        """The worker process, started if need be (under the lock: one pool, one pid)."""
        with self._lock:
            if self._current is None:
                context = worker_context()
                state = context.Array("q", 2)
                pool = concurrent.futures.ProcessPoolExecutor(
                    1, mp_context=context, initializer=_start_worker, initargs=(state,)
                )
                self._current = _Worker(pool, pool.submit(os.getpid), state)
            return self._current

    def start(self) -> None:
        """Start the worker process now, in the background (it imports while the caller
        goes on); idempotent while the worker lives."""
        self._worker()

    def prepare(self) -> None:
        """Start the server its workers fork from (``worker_processes``: it imports their
        code once, ~0.7 s of CPU, in the background), but no worker: the first task's
        worker is then forked ready in milliseconds. Idempotent while the server lives."""
        worker_context()

    @property
    def started(self) -> bool:
        """Whether a worker process was started (and not since closed or lost)."""
        return self._current is not None

    def worker_pid(self, timeout_s: float = 60.0) -> int:
        """The pid of the worker process :meth:`start` started (starting it if need be)."""
        return self._worker().pid.result(timeout_s)

    def run(self, task: AnalysisTask, stop: TaskStop | None = None) -> AnalysisOutcome:
        try:
            outcome = self._within_deadline(run_analysis, task, stop=stop)
        except _Stopped as stopped:
            why = str(stopped)
            return AnalysisOutcome(
                None, None, f"aborted: {why}", os.getpid(), 0, error=why, stopped=True
            )
        except _WorkerLost as lost:
            line = f"the analysis worker process {lost.how} before the {task.kind} did ({lost})"
            return AnalysisOutcome(None, None, f"error: {line}", os.getpid(), 0, error=line)
        self.worker = (outcome.pid, outcome.niceness)
        return outcome

    def call(self, store_url: str | None, fn: Callable[..., T], /, *args: Any) -> T:
        try:
            return self._within_deadline(call_on_store, store_url, fn, args)
        except _WorkerLost as lost:
            name = getattr(fn, "__name__", "analysis")
            line = f"the analysis worker process {lost.how} before {name} did ({lost})"
            raise RuntimeError(line) from lost.__cause__

    def _within_deadline(self, fn: Callable[..., T], *args: Any, stop: TaskStop | None = None) -> T:
        """``fn(*args)`` in the worker; :class:`_WorkerLost` if the worker died, or was
        still at it ``deadline_s`` after it began (then it is killed; a new worker's start-up
        is not counted); :class:`_Stopped` once ``stop`` is requested (a task not begun is
        skipped, one running is killed). A worker killed is dropped and the next task starts
        a new one; a task that only waited behind the killed one runs again there, once."""
        for again in (True, False):
            worker, number = self._worker(), next(self._numbers)
            try:
                worker.pid.result()  # up and imported: the deadline is the task's own
                if stop is not None:  # before the submit: a stop asked meanwhile skips the
                    # task; bound after it, the worker could begin it first and be killed
                    stop.bind(functools.partial(self._end, worker, number))
                try:
                    future = worker.pool.submit(_numbered, number, fn, *args)
                except RuntimeError:  # shut down: killed for another task since taken
                    if not again or worker.killed is None:
                        raise
                    continue
                return future.result(timeout=self.deadline_s)
            except concurrent.futures.TimeoutError as err:
                self._end(worker)
                how = f"was killed after {self.deadline_s:g} s"
                raise _WorkerLost(how, "taken as hung: the deadline of an analysis") from err
            except _Skipped:
                raise _Stopped(stop.reason if stop is not None else "stopped") from None
            except (
                concurrent.futures.process.BrokenProcessPool,
                concurrent.futures.CancelledError,  # still pending as the killed pool shut
            ) as err:
                self._drop(worker)
                if stop is not None and stop.reason is not None:
                    raise _Stopped(stop.reason) from None
                if not again or worker.killed in (None, number):
                    raise _WorkerLost("ended", str(err) or "its pool shut down") from err
            finally:
                if stop is not None:
                    stop.bind(None)
        raise AssertionError("unreachable: the second attempt returns or raises")

    def _end(self, worker: _Worker, number: int | None = None) -> None:
        """The one way a worker is killed: ``worker``'s process is, whatever it runs (the
        deadline), or only while it runs task ``number``, which is otherwise skipped if it has
        not begun (a stop). A killed worker is dropped and a new one started."""
        with worker.state.get_lock():  # the worker begins no task meanwhile
            if number is not None:
                worker.state[1] = number
                if worker.state[0] != number:
                    return
            worker.killed = worker.state[0]
            with contextlib.suppress(ProcessLookupError):
                os.kill(worker.pid.result(), signal.SIGKILL)
        self._drop(worker)
        self.start()  # the next task finds its successor imported

    def _drop(self, worker: _Worker) -> None:
        """Forget ``worker`` (a dead or killed one) so the next task starts a new one."""
        with self._lock:
            if self._current is worker:
                self._current = None
        worker.pool.shutdown(wait=False, cancel_futures=True)

    def close(self) -> None:
        with self._lock:
            worker, self._current = self._current, None
        if worker is not None:
            worker.pool.shutdown(wait=True, cancel_futures=True)


class _WorkerLost(Exception):
    """The worker process is gone before its task ended: ``how`` (a phrase), and why as the
    message."""

    def __init__(self, how: str, why: str) -> None:
        super().__init__(why)
        self.how = how


class _Stopped(Exception):
    """The task's :class:`TaskStop` was requested: it was skipped or its worker killed; the
    reason is the message."""


class ThreadExecutor:
    """Runs tasks in the calling thread on ``store`` (a database only this process can open,
    or a test that patches the fit in this process)."""

    cannot_stop: str | None = (
        "its fit runs inside the service's own process (a database only the service opens), "
        "where it cannot be stopped once started"
    )

    def __init__(self, store: Store) -> None:
        self.store = store

    def run(self, task: AnalysisTask, stop: TaskStop | None = None) -> AnalysisOutcome:
        return run_analysis(task, self.store)  # ``cannot_stop``: the stop is not heard

    def call(self, store_url: str | None, fn: Callable[..., T], /, *args: Any) -> T:
        return fn(*args) if store_url is None else fn(self.store, *args)

    def close(self) -> None:
        """Nothing to release: tasks ran in their callers' threads."""


_SHARED = ProcessExecutor()
# Closed before the interpreter tears its modules down (else the pool's finaliser runs on a
# half-finalised ``multiprocessing`` and prints an ignored AttributeError at every exit).
atexit.register(_SHARED.close)


def shared_process_executor() -> ProcessExecutor:
    """This process's analysis worker: one per process, whatever the services started in it
    (``rig serve`` starts one; a test session many, each reusing the warm worker). Its
    process ends with this one (``concurrent.futures`` joins it at exit, after the task
    running)."""
    return _SHARED


def executor_for(store: Store) -> AnalysisExecutor:
    """The process's worker for a database others can open, else the calling thread."""
    return shared_process_executor() if shared_by_processes(store.url) else ThreadExecutor(store)
