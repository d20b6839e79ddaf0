"""Room to record: the free space where a run's rows and spill files go, checked before a
run is accepted, so a full disk refuses the start instead of failing the run."""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import sqlalchemy as sa

from daq.store.faults import StorageFull, database_name, sqlite_file

if TYPE_CHECKING:
    from daq.store.store import Store

#: Least free space a run needs where it is stored, bytes: a 10-minute tow at 100 Hz is
#: ~6 MB of rows; this leaves room for the WAL, the spill file and a few runs more.
MIN_FREE_BYTES = 64 * 1024 * 1024
#: Sets another threshold, bytes (0 turns the check off).
MIN_FREE_ENV = "RIG_MIN_FREE_BYTES"


def min_free_bytes() -> int:
    """``$RIG_MIN_FREE_BYTES`` if set, else ``MIN_FREE_BYTES``; ``ValueError`` naming the
    variable for anything but a whole number ≥ 0."""
    text = os.environ.get(MIN_FREE_ENV, "").strip()
    if not text:
        return MIN_FREE_BYTES
    value = int(text) if text.isdigit() else -1
    if value < 0:
        raise ValueError(
            f"{MIN_FREE_ENV}: {text!r} is not allowed (allowed: a whole number of bytes ≥ 0; "
            "0 turns the free-space check off)"
        )
    return value


def _existing(path: Path) -> Path:
    """``path``, else its nearest folder that exists (where it would be made)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path("/")


def free_space(store: Store) -> list[tuple[str, Path, int]]:
    """(how messages name it, folder, free bytes) of each place a run writes to: a SQLite
    database's folder and the spill folder (a server's disk is the server's to watch)."""
    places: list[tuple[str, Path]] = []
    url = sa.make_url(store.url)
    if (file := sqlite_file(url)) is not None:
        places.append((f"the folder of {database_name(url)}", file.parent))
    places.append(("the spill folder ($RIG_SPILL_DIR)", store.spill_dir))
    return [(name, path, shutil.disk_usage(_existing(path)).free) for name, path in places]


def check_room(store: Store, least: int | None = None) -> None:
    """Raise :class:`StorageFull` when a place a run writes to has less than ``least``
    bytes free (default :func:`min_free_bytes`)."""
    least = min_free_bytes() if least is None else least
    if least == 0:
        return
    for name, _, free in free_space(store):
        if free < least:
            raise StorageFull(database_name(sa.make_url(store.url)), name, free, least)
