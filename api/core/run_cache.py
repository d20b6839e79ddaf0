"""Serialised metadata of ended runs, kept in memory for fast repeated reads.

A run that has ended (completed, aborted, interrupted) never changes, except for its
free ``metadata`` (annotations, by this process or another). So an entry remembers the
metadata it was built with and is served only while the stored metadata is the same
(one indexed read of one column); running runs and id prefixes always go to the database.

That read stays on every hit: another process on the same database (``rig runs
annotate``, a second service) can annotate an ended run, and nothing cheaper tells this
one so. SQLite has no cross-process notification, and its ``PRAGMA data_version`` is per
connection and moves with every sample a running run writes; a time-to-live would serve
another process's annotation stale. The read is one column of one row by its unique
index, against a full run record and its JSON on a miss.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from collections.abc import Callable

from daq.store import RunInfo
from daq.vocabulary import ENDED_STATUSES


class EndedRunCache:
    """A bounded LRU of ``run id → JSON bytes`` for ended runs."""

    def __init__(self, max_runs: int = 1000) -> None:
        self.max_runs = max_runs
        self._items: OrderedDict[tuple[str, bool], tuple[dict, bytes]] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(
        self, run_id: str, include_toml: bool, stored_metadata: Callable[[str], dict | None]
    ) -> bytes | None:
        """The remembered JSON, if any and ``stored_metadata(run_id)`` is still the same."""
        with self._lock:
            item = self._items.get((run_id, include_toml))
        if item is None or stored_metadata(run_id) != item[0]:
            with self._lock:
                self.misses += 1
            return None
        with self._lock:
            self._items.move_to_end((run_id, include_toml))
            self.hits += 1
        return item[1]

    def put(self, run: RunInfo, include_toml: bool, *, stored: bool = True) -> bytes:
        """The run's JSON; remembered when the run has ended and that end is ``stored``
        (not an end still waiting for the database: its samples may yet come)."""
        body = json.dumps(run.to_json(include_toml=include_toml), allow_nan=False).encode()
        if run.status in ENDED_STATUSES and stored:
            with self._lock:
                self._items[(run.id, include_toml)] = (run.metadata, body)
                while len(self._items) > self.max_runs:
                    self._items.popitem(last=False)
        return body
