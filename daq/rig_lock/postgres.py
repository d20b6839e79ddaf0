"""The PostgreSQL part of a lease: advisory locks on one watched connection.

Every device of the rig is one ``pg_try_advisory_lock(key1, key2)`` (``key1`` = "towr",
``key2`` from the device's hash) held by a connection of the lease's own; the holder's
description is that connection's ``application_name`` (63 bytes, see
``pg_stat_activity``). The server drops the locks when the connection ends. The holder
renews every 0.2 s with one cheap query on that connection (do I still hold every key?):
a terminated backend, a restarted server or a lock no longer granted is a lost lease at
the next renewal; a server that vanished from the network fails the query within about
2 s (``tcp_user_timeout``, ``statement_timeout``).
"""

from __future__ import annotations

import contextlib
import threading

import sqlalchemy as sa

from daq.rig_lock.holder import LockHolder
from daq.rig_lock.leased_devices import Device

#: First half of every advisory-lock key: "towr" (the second half is the device's).
PG_LOCK_CLASS = int.from_bytes(b"towr", "big") & 0x7FFFFFFF

#: The lock connection's server-side settings: a vanished client is noticed by the server
#: (its locks dropped) within about 10 s, and no statement hangs a renewal beyond 2 s.
SERVER_SETTINGS = {
    "tcp_keepalives_idle": "5",
    "tcp_keepalives_interval": "2",
    "tcp_keepalives_count": "2",
    "statement_timeout": "2000",
}

_HOLDER_QUERY = sa.text(
    "SELECT a.application_name, a.pid FROM pg_locks l "
    "JOIN pg_stat_activity a ON a.pid = l.pid "
    "WHERE l.locktype = 'advisory' AND l.granted AND l.objsubid = 2 "
    "AND l.classid = CAST(:a AS oid) AND l.objid = CAST(:b AS oid) "
    "AND l.database = (SELECT oid FROM pg_database WHERE datname = current_database())"
)
_MINE_QUERY = sa.text(
    "SELECT l.objid::bigint FROM pg_locks l WHERE l.locktype = 'advisory' AND l.granted "
    "AND l.pid = pg_backend_pid() AND l.objsubid = 2 AND l.classid = CAST(:a AS oid)"
)


def advisory_key(device: Device) -> int:
    """The second half of ``device``'s advisory-lock key (31 bits of its hash)."""
    return int.from_bytes(device.digest()[:4], "big") & 0x7FFFFFFF


def lease_holders(conn: sa.Connection) -> set[tuple[str, int]]:
    """(host, pid) of every process holding some rig's lease in this database (host cut
    to the 24 characters ``application_name`` keeps)."""
    rows = conn.execute(
        sa.text(
            "SELECT DISTINCT a.application_name, a.pid FROM pg_locks l "
            "JOIN pg_stat_activity a ON a.pid = l.pid WHERE l.locktype = 'advisory' "
            "AND l.granted AND l.classid = CAST(:a AS oid)"
        ),
        {"a": PG_LOCK_CLASS},
    ).all()
    found = (LockHolder.from_pg_name(row.application_name or "", row.pid) for row in rows)
    return {(h.host[:24], h.pid) for h in found}


class PgLease:
    """Advisory locks on ``devices``, held and renewed on one connection."""

    def __init__(self, url: str, devices: list[Device]) -> None:
        self.devices = devices
        self.keys = {advisory_key(d): d for d in devices}
        self._engine = sa.create_engine(
            url,
            poolclass=sa.pool.NullPool,
            connect_args={"keepalives": 1, "keepalives_idle": 5, "keepalives_interval": 2,
                          "keepalives_count": 2, "tcp_user_timeout": 2000,
                          "connect_timeout": 10},
        )  # fmt: skip
        self._conn: sa.Connection | None = None
        #: The server process of the lock's connection (``pg_terminate_backend`` ends it).
        self.backend_pid: int | None = None
        self._io = threading.Lock()  # one statement at a time on the connection

    def acquire(self, holder: LockHolder) -> Device | None:
        """Take every device's lock; returns the first device someone else holds (having
        taken none), or None when all are held."""
        conn = self._engine.connect().execution_options(isolation_level="AUTOCOMMIT")
        try:
            for name, value in SERVER_SETTINGS.items():
                conn.execute(sa.text("SELECT set_config(:n, :v, false)"), {"n": name, "v": value})
            for key, device in self.keys.items():
                got = conn.execute(
                    sa.text("SELECT pg_try_advisory_lock(:a, :b)"), {"a": PG_LOCK_CLASS, "b": key}
                ).scalar_one()
                if not got:
                    conn.close()  # drops the ones taken so far
                    return device
            self.backend_pid = conn.execute(sa.text("SELECT pg_backend_pid()")).scalar_one()
        except BaseException:
            conn.close()
            raise
        self._conn = conn
        self.publish(holder)
        return None

    def renew(self) -> str | None:
        """None while every lock is still held on a live connection, else why not."""
        with self._io:
            if self._conn is None:
                return "its PostgreSQL connection is closed"
            try:
                held = set(self._conn.execute(_MINE_QUERY, {"a": PG_LOCK_CLASS}).scalars())
            except Exception as err:
                text = " ".join(str(getattr(err, "orig", None) or err).split())[:200]
                return f"the PostgreSQL connection holding it failed ({text})"
        missing = [str(d) for k, d in self.keys.items() if k not in held]
        if missing:
            return "PostgreSQL no longer grants it for " + ", ".join(missing)
        return None

    def publish(self, holder: LockHolder) -> None:
        with self._io:
            if self._conn is not None:
                with contextlib.suppress(Exception):
                    self._conn.execute(
                        sa.text("SELECT set_config('application_name', :v, false)"),
                        {"v": holder.to_pg_name()},
                    )

    def holder_of(self, device: Device) -> LockHolder | None:
        """Who holds ``device``'s lock in this database (None when free)."""
        with self._engine.connect() as conn:
            row = conn.execute(
                _HOLDER_QUERY, {"a": PG_LOCK_CLASS, "b": advisory_key(device)}
            ).first()
        if row is None:
            return None
        return LockHolder.from_pg_name(row.application_name or "", row.pid)

    def release(self) -> None:
        """Unlock and close the connection (closing drops the locks anyway). Never raises."""
        with self._io:
            conn, self._conn = self._conn, None
            if conn is not None:
                with contextlib.suppress(Exception):
                    conn.execute(sa.text("SELECT pg_advisory_unlock_all()"))
                with contextlib.suppress(Exception):
                    conn.close()
        self._engine.dispose()
