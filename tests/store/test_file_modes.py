"""The files a store creates are its owner's alone (issue 19): the SQLite database with its
-wal and -shm files and the spill files are 0600, their new folders 0700, whatever the
umask lets through; a database that exists keeps the mode it was given."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from pathlib import Path

import pytest

from daq.store import RunRecorder, Store
from tests.store.helpers import DbLimits, make_samples, new_run


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


@pytest.fixture
def open_umask() -> Iterator[None]:
    """The usual umask (0022): files would be 0644 unless created private."""
    before = os.umask(0o022)
    try:
        yield
    finally:
        os.umask(before)


async def test_database_and_spill_files_are_created_0600(tmp_path, open_umask):
    folder, spill = tmp_path / "data" / "towrig", tmp_path / "state" / "spill"
    store = Store(f"sqlite:///{folder / 'rig.db'}", spill_dir=spill)
    try:
        run_id = new_run(store)
        recorder = RunRecorder(store, run_id, flush_interval_s=0.1)
        DbLimits(store).set(read_only=True)  # the samples go to the spill file
        for sample in make_samples(0, 5):
            recorder.put(sample)
        await recorder.flush()
        assert recorder.fault is not None and recorder.spill.path.exists()
        files = {p.name: _mode(p) for p in folder.iterdir()}
        assert files == {"rig.db": 0o600, "rig.db-wal": 0o600, "rig.db-shm": 0o600}
        assert _mode(folder) == 0o700
        assert _mode(recorder.spill.path) == 0o600 and _mode(spill) == 0o700
        recorder.spill.close(remove=False)
    finally:
        store.close()


def test_an_existing_database_keeps_its_mode(tmp_path, open_umask):
    path = tmp_path / "shared.db"
    Store(f"sqlite:///{path}").close()
    path.chmod(0o640)  # a lab's choice (a group that reads the runs)
    Store(f"sqlite:///{path}").close()
    assert _mode(path) == 0o640
