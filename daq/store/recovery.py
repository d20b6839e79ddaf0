"""Which runs left ``running`` belong to a process that no longer drives the rig: the store
marks them ``interrupted`` when it opens (``Store.recover_interrupted`` writes the endings;
this module only decides, so it needs no store)."""

from __future__ import annotations

import socket
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sqlalchemy as sa

from daq.store.database import process_alive
from daq.store.schema import runs as runs_t
from daq.store.schema import sample_blocks
from daq.store.spill import spilled_ends

#: A run of another host whose process holds no lease is marked interrupted only once its
#: last sample is this old, s (its process may have lost the lease and still be writing
#: its own ending: the recorder retries that for up to 30 s).
OTHER_HOST_GRACE_S = 45.0


@dataclass(frozen=True)
class Interruption:
    """A run to end as ``interrupted``: its row, the reason (naming its process), the stop
    time (unix s: its last stored sample, or its start) and the fault event to record."""

    run: sa.Row[Any]
    reason: str
    stopped_at: float

    @property
    def event_message(self) -> str:
        return f"run {self.run.uuid} interrupted: {self.reason}; recovered at start-up"

    @property
    def event_data(self) -> dict[str, Any]:
        return {"owner_host": self.run.owner_host, "owner_pid": self.run.owner_pid}


def interrupted_runs(
    conn: sa.Connection, backend: str, spill_dir: Path, *, include_live_owners: bool = False
) -> list[Interruption]:
    """The runs left ``running`` by a process that no longer drives the rig, read on
    ``conn`` (the caller's transaction, which ends them); ``backend`` is the dialect name
    and ``spill_dir`` the store's folder of spill files.

    A run recorded on this host is left alone while its process (pid, boot and start
    time) is alive. One recorded on another host (PostgreSQL) is left alone while its
    process holds a rig's lease in this database (``daq.rig_lock``), or while its last
    sample is younger than ``OTHER_HOST_GRACE_S`` (a process that lost its lease may
    still be writing its own ending); imported runs from another host are left alone.
    ``include_live_owners`` marks them all. A run whose ending waits in a spill file
    (its recorder ended it while storage failed) is never marked: the write-back stores
    that ending.
    """
    here = socket.gethostname()
    found: list[Interruption] = []
    spilled = spilled_ends(spill_dir)  # ended, the ending waiting in a side file
    running = conn.execute(sa.select(runs_t).where(runs_t.c.status == "running")).all()
    holders = None
    if running and backend == "postgresql":
        from daq.rig_lock.postgres import lease_holders

        holders = lease_holders(conn)
    for run in running:
        last_wall = conn.execute(
            sa.select(sa.func.max(sample_blocks.c.t_wall_max)).where(
                sample_blocks.c.run_id == run.id
            )
        ).scalar()
        last = run.started_at if last_wall is None else max(last_wall, run.started_at)
        owner = f"recording process pid {run.owner_pid} on host {run.owner_host}"
        if run.owner_host == here or holders is None:
            owner_alive = run.owner_host != here or (
                run.owner_pid is not None
                and process_alive(run.owner_pid, run.owner_boot_id, run.owner_start_ticks)
            )
            reason = f"{owner} ended without finishing the run"
        else:
            owner_alive = (
                (str(run.owner_host)[:24], run.owner_pid) in holders
                or run.source != "recorded"
                or time.time() - last < OTHER_HOST_GRACE_S
            )
            reason = f"{owner} no longer holds the rig; it ended without finishing the run"
        if (owner_alive and not include_live_owners) or run.uuid in spilled:
            continue
        found.append(Interruption(run, reason, last))
    return found
