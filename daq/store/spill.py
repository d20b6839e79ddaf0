"""The side file of a run whose database stopped taking writes.

When storage fails, the recorder appends every sample (and event, and finally the run's
intended end) it could not store to ``<spill dir>/<run uuid>.jsonl``, one JSON record a
line, fsynced. :func:`replay_spills` writes such files back into a store that holds the
run (on the next open of the store, or before the next run starts) and deletes them.
Spill files are created 0600 in a 0700 directory: they hold a run's samples.

The recorder holds an exclusive ``flock`` on its file while it lives, so a store opened
by another process never replays a run that is still being recorded.
"""

from __future__ import annotations

import asyncio
import fcntl
import json
import logging
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Protocol

from daq.sample import Quality, Sample
from daq.store.faults import StorageUnavailable, one_line
from daq.store.pending_ends import PendingEnds
from daq.store.run_records import EventInfo, RunInfo, RunNotFound

log = logging.getLogger(__name__)

SUFFIX = ".jsonl"


class SpillTarget(Protocol):
    """What a write-back needs of the store it writes into (:class:`daq.store.Store`)."""

    spill_dir: Path
    pending_ends: PendingEnds

    def get_run(self, run_id_or_unique_prefix: str, *, as_stored: bool = False) -> RunInfo: ...
    def add_samples(
        self, run_id: str, samples: Sequence[Sample], *, skip_existing: bool = False
    ) -> int: ...
    def events(self, run_id: str | None = None, *, limit: int | None = None) -> list[EventInfo]: ...
    def add_event(
        self,
        run_id: str | None,
        kind: str,
        message: str,
        data: dict | None = None,
        *,
        t_wall: float | None = None,
    ) -> None: ...
    def finish_run(
        self,
        run_id: str,
        status: str,
        reason: str | None = None,
        *,
        stopped_at: datetime | float | None = None,
    ) -> None: ...


def default_spill_dir() -> Path:
    """``$RIG_SPILL_DIR``, else ``$XDG_STATE_HOME/towrig/spill`` (``~/.local/state/...``)."""
    given = os.environ.get("RIG_SPILL_DIR", "").strip()
    if given:
        return Path(given).expanduser()
    state = os.environ.get("XDG_STATE_HOME", "").strip() or str(Path.home() / ".local/state")
    return Path(state) / "towrig" / "spill"


@dataclass
class PendingEvent:
    """An event of the run waiting to be stored; ``t_wall`` is when it happened."""

    kind: str
    message: str
    data: dict[str, Any] | None
    t_wall: float
    spilled: bool = False


class SpillFile:
    """Append-only side file of one run (created, locked and fsynced on first use)."""

    def __init__(self, directory: Path, run_id: str) -> None:
        self.path = Path(directory) / f"{run_id}{SUFFIX}"
        self._file: IO[str] | None = None

    @property
    def used(self) -> bool:
        return self._file is not None

    def _open(self) -> IO[str]:
        if self._file is None:
            self.path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
            # 0600: the samples of a run are no other local user's to read
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_CLOEXEC, 0o600)
            f = os.fdopen(fd, "a", encoding="utf-8")
            fcntl.flock(f, fcntl.LOCK_EX)
            self._file = f
        return self._file

    def append(
        self,
        samples: Iterable[Sample] = (),
        events: Iterable[PendingEvent] = (),
        end: tuple[str, str | None, float] | None = None,
    ) -> None:
        """Write records and fsync (raises OSError when the side file cannot be written)."""
        lines = [
            json.dumps(
                {
                    "s": [
                        s.seq,
                        s.t_mono,
                        s.t_wall,
                        int(s.quality),
                        list(s.stale),
                        s.channels,
                    ]
                }
            )
            for s in samples
        ]
        lines += [json.dumps({"e": [e.t_wall, e.kind, e.message, e.data]}) for e in events]
        if end is not None:
            lines.append(json.dumps({"end": list(end)}))
        if not lines:
            return
        f = self._open()
        f.write("\n".join(lines) + "\n")
        f.flush()
        os.fsync(f.fileno())

    def close(self, *, remove: bool) -> None:
        """Release the lock; ``remove`` deletes the file (everything in it is stored)."""
        if self._file is None:
            return
        if remove:
            self.path.unlink(missing_ok=True)
        self._file.close()
        self._file = None


@dataclass
class SpillContents:
    samples: list[Sample]
    events: list[PendingEvent]
    end: tuple[str, str | None, float] | None


def read_spill(path: Path) -> SpillContents:
    """The records of a side file; a line cut short by a crash is ignored."""
    samples: list[Sample] = []
    events: list[PendingEvent] = []
    end = None
    with open(path, encoding="utf-8") as f:
        for line in f:
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                continue  # the last line of a process that died mid-write
            if "s" in record:
                seq, t_mono, t_wall, quality, stale, channels = record["s"]
                samples.append(
                    Sample(seq, t_mono, t_wall, channels, Quality(quality), tuple(stale))
                )
            elif "e" in record:
                t_wall, kind, message, data = record["e"]
                events.append(PendingEvent(kind, message, data, t_wall))
            elif "end" in record:
                status, reason, stopped_at = record["end"]
                end = (status, reason, stopped_at)
    return SpillContents(samples, events, end)


def spilled_ends(directory: Path) -> set[str]:
    """Ids of the runs whose ending waits in a side file of ``directory`` (their recorder
    ended them while storage failed; the write-back stores that ending)."""
    found: set[str] = set()
    try:
        paths = list(Path(directory).glob(f"*{SUFFIX}"))
    except OSError:
        return found
    for path in paths:
        try:
            if read_spill(path).end is not None:
                found.add(path.stem)
        except OSError:
            continue
    return found


async def write_back_later(store: SpillTarget, path: Path, *, max_delay_s: float = 60.0) -> None:
    """Retry :func:`replay_spills` (1 s doubling to ``max_delay_s``) until ``path`` is
    written back: a long-lived process (``rig serve``) ends a run as soon as storage
    allows, without waiting for the next run or a restart."""
    delay = 1.0
    while path.exists():
        await asyncio.sleep(delay)
        await asyncio.to_thread(replay_spills, store, path.parent)
        delay = min(2 * delay, max_delay_s)


def replay_spills(
    store: SpillTarget, directory: Path | None = None, *, database_errors: bool = False
) -> list[str]:
    """Write back every side file in ``directory`` whose run is in ``store``; returns their
    run ids. Files of other databases, of live recorders, or that still cannot be written
    stay for later (logged). ``database_errors``: re-raise the database's own failure to
    take them (:class:`StorageUnavailable`: full, unreachable; after trying every file): the storage
    still fails."""
    directory = Path(directory) if directory is not None else store.spill_dir
    try:
        paths = sorted(directory.glob(f"*{SUFFIX}"))
    except OSError:
        return []
    replayed = []
    failed: StorageUnavailable | None = None
    for path in paths:
        try:
            if _replay_one(store, path):
                replayed.append(path.stem)
        except Exception as exc:
            log.warning("spill file %s not written back yet: %s", path, one_line(exc))
            if isinstance(exc, StorageUnavailable):
                failed = exc
    if database_errors and failed is not None:
        raise failed
    return replayed


def _replay_one(store: SpillTarget, path: Path) -> bool:
    try:
        f = open(path, encoding="utf-8")  # noqa: SIM115 - closed below
    except FileNotFoundError:
        return False  # another process replayed it
    with f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False  # its recorder is still running
        if not path.exists():
            return False
        run_id = path.stem
        try:
            run = store.get_run(run_id)
        except (RunNotFound, ValueError):
            return False  # a run of another database
        contents = read_spill(path)
        for start in range(0, len(contents.samples), 50_000):
            store.add_samples(run_id, contents.samples[start : start + 50_000], skip_existing=True)
        stored = [(e.time.timestamp(), e.kind, e.message) for e in store.events(run_id)]
        for e in contents.events:
            if not any(
                abs(t - e.t_wall) < 1e-3 and (k, m) == (e.kind, e.message) for t, k, m in stored
            ):
                store.add_event(run_id, e.kind, e.message, e.data, t_wall=e.t_wall)
        if contents.end is not None and store.get_run(run_id, as_stored=True).status == "running":
            status, reason, stopped_at = contents.end
            store.finish_run(run_id, status, reason, stopped_at=stopped_at)
        store.pending_ends.discard(run.id)  # stored now (or the run was ended otherwise)
        path.unlink()
    log.warning(
        "run %s: wrote back %d samples and %d events kept in %s while storage failed",
        run.id,
        len(contents.samples),
        len(contents.events),
        path,
    )
    return True
