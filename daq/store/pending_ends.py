"""Ends of runs decided in this process that the database has not taken yet.

When a procedure stops, its recorder knows how the run ended (``completed``, or
``aborted`` with a reason) and when, but the database may refuse or delay the write (disk
full, a held lock): the end then waits in the run's spill file until storage takes it.
Meanwhile the store of the recording process answers with this truth instead of the
``running`` the database still holds, so the API reports the run as it ended on the rig
from the moment the procedure stopped. An entry goes when the end is written (by the
recorder, or by the write-back of the spill file).
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass

from daq.store.run_records import RunInfo, to_datetime


@dataclass(frozen=True)
class RunEnd:
    """How a run ended: status, reason (None for ``completed``), stop time (Unix s)."""

    status: str
    reason: str | None
    stopped_at: float


class PendingEnds:
    """Run id → :class:`RunEnd` not yet stored; shared by the rig thread (the recorder)
    and the HTTP threads (readers), so every access holds a lock."""

    def __init__(self) -> None:
        self._ends: dict[str, RunEnd] = {}
        self._lock = threading.Lock()

    def set(self, run_id: str, status: str, reason: str | None, stopped_at: float) -> None:
        """Remember the end of ``run_id`` until :meth:`discard`."""
        with self._lock:
            self._ends[run_id] = RunEnd(status, reason, stopped_at)

    def discard(self, run_id: str) -> None:
        """The end is stored (or the run ended otherwise): forget it."""
        with self._lock:
            self._ends.pop(run_id, None)

    def get(self, run_id: str) -> RunEnd | None:
        with self._lock:
            return self._ends.get(run_id)

    def __len__(self) -> int:
        with self._lock:
            return len(self._ends)

    def apply(self, run: RunInfo) -> RunInfo:
        """``run`` as it ended, when the database still says ``running`` and this process
        knows better; otherwise ``run`` unchanged."""
        if run.status != "running":
            return run
        end = self.get(run.id)
        if end is None:
            return run
        return dataclasses.replace(
            run, status=end.status, reason=end.reason, stopped_at=to_datetime(end.stopped_at)
        )
