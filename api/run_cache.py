"""Serialised metadata of ended runs, kept in memory for fast repeated reads.

A run that has ended (completed, aborted, interrupted) never changes its metadata, so
its JSON can be built once and served from memory; running runs and id prefixes always
go to the database.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict

from daq.store import RunInfo
from daq.vocabulary import ENDED_STATUSES


class EndedRunCache:
    """A bounded LRU of ``run id → JSON bytes`` for ended runs."""

    def __init__(self, max_runs: int = 1000) -> None:
        self.max_runs = max_runs
        self._items: OrderedDict[tuple[str, bool], bytes] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, run_id: str, include_toml: bool) -> bytes | None:
        with self._lock:
            body = self._items.get((run_id, include_toml))
            if body is None:
                self.misses += 1
                return None
            self._items.move_to_end((run_id, include_toml))
            self.hits += 1
            return body

    def put(self, run: RunInfo, include_toml: bool) -> bytes:
        """The run's JSON; remembered when the run has ended."""
        body = json.dumps(run.to_json(include_toml=include_toml), allow_nan=False).encode()
        if run.status in ENDED_STATUSES:
            with self._lock:
                self._items[(run.id, include_toml)] = body
                while len(self._items) > self.max_runs:
                    self._items.popitem(last=False)
        return body
