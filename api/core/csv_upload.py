"""CSV import off the clock's process.

The upload is streamed to a temporary file (the service holds one chunk at a time) and
parsed and stored by a short-lived child process (niced; forked from the server that
preloaded the import's code, ``api.core.worker_processes``, so it starts in milliseconds
instead of importing NumPy and the store for ~0.7 s of CPU), so neither the parse of up to
``MAX_IMPORT_ROWS`` rows nor its garbage collection ever holds the GIL the acquisition
clock's thread needs. A database only this process can open (in-memory SQLite) falls back
to a worker thread.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

from starlette.concurrency import run_in_threadpool

from api.core.worker_processes import worker_context
from daq.csv_to_store import import_csv
from daq.priority import lower_priority
from daq.store import Store
from daq.store.migrate import shared_by_processes

#: Niceness of the import process: it yields the CPU to the service and the clock.
IMPORT_NICENESS = 10


async def save_stream(chunks: AsyncIterator[bytes], path: Path) -> int:
    """Write the request body to ``path`` chunk by chunk; returns its size (bytes)."""
    size = 0
    with open(path, "wb") as f:
        async for chunk in chunks:
            f.write(chunk)
            size += len(chunk)
    return size


def _import(url: str, path: Path, kind: str, options: dict[str, Any]) -> tuple[str, int]:
    store = Store(url)
    try:
        run_id = import_csv(store, path, kind=kind, **options)
        return run_id, store.get_run(run_id).sample_count
    finally:
        store.close()


async def import_file(store: Store, path: Path, *, kind: str, **options: Any) -> tuple[str, int]:
    """Import ``path`` as a completed run; returns (run id, sample count).

    ``options``: the keyword arguments of ``daq.store.import_csv`` (parameters, vehicle,
    time_unit, release_time_s, end_time_s)."""
    if not shared_by_processes(store.url):

        def local() -> tuple[str, int]:
            run_id = import_csv(store, path, kind=kind, **options)
            return run_id, store.get_run(run_id).sample_count

        return await run_in_threadpool(local)
    pool = ProcessPoolExecutor(
        1,
        mp_context=worker_context(),
        initializer=lower_priority,  # normal scheduling: a real-time service thread starts it
        initargs=(IMPORT_NICENESS,),
    )
    try:
        return await asyncio.wrap_future(pool.submit(_import, store.url, path, kind, options))
    finally:
        await asyncio.to_thread(pool.shutdown)
