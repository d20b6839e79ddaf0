"""One rig, one driver: a lock on the rig that holds across processes and hosts.

Every process that opens a rig's devices (``rig serve``, ``rig tow``, …) first takes the
rig's lock in the database it records to, keyed on the rig's name from the rig file, and
holds it until its session is closed. A second process is refused at once, with who holds
the rig::

    rig 'BENBAM tow tank' is in use by `rig serve` pid 1234 on host lab-pc
    since 2026-11-23 16:02:11 (tow 24.5 N, run 3f2a9c1b)

How it is held depends on the database:

* **PostgreSQL** — ``pg_try_advisory_lock`` on a connection of its own, kept open for the
  lock's life. The server drops the lock when that connection ends, however the process
  ended (TCP keepalives are set so a vanished host is noticed within about half a minute).
  Who holds it is the connection's ``application_name`` (visible in ``pg_stat_activity``).
* **SQLite** — an OS lock (``flock``) on a small file beside the database
  (``rig.db.rig-<name>.lock``) holding the holder's description. SQLite in WAL mode already
  requires every user of the database to be on one host, and the kernel drops the lock
  when the holder dies, even by SIGKILL: no heartbeat, no pid check, no stale lock.
* **in-memory SQLite** — a lock inside this process only (nothing else can see the
  database anyway).
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import re
import socket
import sys
import threading
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import ClassVar

import sqlalchemy as sa

#: First half of the PostgreSQL advisory-lock key: "towr" (the second half is the rig's).
PG_LOCK_CLASS = int.from_bytes(b"towr", "big") & 0x7FFFFFFF
#: PostgreSQL keeps ``application_name`` to 63 bytes.
PG_NAME_BYTES = 63


@dataclass(frozen=True)
class LockHolder:
    """Who holds a rig: the program, its process and host, since when, doing what."""

    program: str
    pid: int
    host: str
    since: float  # Unix time, s
    activity: str | None = None

    def describe(self) -> str:
        """```rig serve` pid 1234 on host lab-pc since 2026-11-23 16:02:11 (tow 24.5 N)``"""
        when = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(self.since))
        text = f"`{self.program}` pid {self.pid} on host {self.host} since {when}"
        return text + (f" ({self.activity})" if self.activity else "")

    # -- compact form for PostgreSQL's application_name (63 bytes) -------------------------
    def to_pg_name(self) -> str:
        fields = [str(self.pid), str(int(self.since)), self.program, self.host[:24]]
        text = "|".join(f.replace("|", "/") for f in fields)
        if self.activity:
            text += "|" + self.activity.replace("|", "/")
        return text.encode()[:PG_NAME_BYTES].decode(errors="ignore")

    @classmethod
    def from_pg_name(cls, text: str, fallback_pid: int) -> LockHolder:
        parts = text.split("|", 4)
        if len(parts) < 4 or not parts[0].isdigit() or not parts[1].isdigit():
            return cls(text or "unknown program", fallback_pid, "unknown", time.time())
        activity = parts[4] if len(parts) > 4 and parts[4] else None
        return cls(parts[2], int(parts[0]), parts[3], float(parts[1]), activity)


def this_process(program: str | None = None) -> LockHolder:
    """A holder description of this process (``program`` defaults to ``rig <command>``)."""
    return LockHolder(program or program_name(), os.getpid(), socket.gethostname(), time.time())


def program_name() -> str:
    """``rig tow`` for the CLI, else the script's name."""
    script = Path(sys.argv[0]) if sys.argv and sys.argv[0] else Path("python")
    name = script.parent.name if script.name == "__main__.py" else script.name
    if name == "rig" and len(sys.argv) > 1:
        return f"rig {sys.argv[1]}"
    return name


class RigInUse(RuntimeError):
    """Another process (or session) holds the rig."""

    def __init__(self, rig_name: str, holder: LockHolder | None) -> None:
        self.rig_name = rig_name
        self.holder = holder
        who = holder.describe() if holder else "another process (it is just starting)"
        super().__init__(f"rig '{rig_name}' is in use by {who}")


def rig_key(rig_name: str) -> str:
    """The rig's identity: its name from the rig file, case and spacing folded."""
    return " ".join(rig_name.casefold().split())


class RigLock:
    """The lock on one rig in one database; ``acquire`` raises :class:`RigInUse`."""

    def __init__(self, rig_name: str, holder: LockHolder) -> None:
        self.rig_name = rig_name
        self.key = rig_key(rig_name)
        self.me = holder
        self.held = False
        self._guard = threading.Lock()

    def acquire(self) -> None:
        with self._guard:
            if self.held:
                return
            self.me = replace(self.me, since=time.time(), activity=None)
            if not self._try_acquire():
                raise RigInUse(self.rig_name, self._holder())
            self.held = True

    def release(self) -> None:
        """Give the rig back (never raises)."""
        with self._guard:
            if self.held:
                self.held = False
                with contextlib.suppress(Exception):
                    self._release()

    def set_activity(self, activity: str | None) -> None:
        """Say what this holder is doing (shown to whoever is refused)."""
        with self._guard:
            self.me = replace(self.me, activity=activity)
            if self.held:
                with contextlib.suppress(Exception):
                    self._publish()

    def holder(self) -> LockHolder | None:
        """Who holds the rig now (``None`` when free)."""
        with self._guard:
            if self.held:
                return self.me
            return self._holder()

    def check(self) -> None:
        """Make sure the lock is still held; raise :class:`RigInUse` if it was lost."""

    def __enter__(self) -> RigLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    # -- per backend ------------------------------------------------------------------------
    def _try_acquire(self) -> bool:
        raise NotImplementedError

    def _release(self) -> None:
        raise NotImplementedError

    def _publish(self) -> None:
        raise NotImplementedError

    def _holder(self) -> LockHolder | None:
        raise NotImplementedError


class FileRigLock(RigLock):
    """``flock`` on a file beside an SQLite database; the file says who holds it."""

    #: The description is written padded to this size, in place, so a reader never sees
    #: the file empty between a truncate and a write.
    RECORD_BYTES = 1024

    def __init__(self, path: Path, rig_name: str, holder: LockHolder) -> None:
        super().__init__(rig_name, holder)
        self.path = path
        self._fd: int | None = None

    def _try_acquire(self) -> bool:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        self._fd = fd
        self._publish()
        return True

    def _release(self) -> None:
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)  # closing the last descriptor drops the flock

    def _publish(self) -> None:
        assert self._fd is not None
        record = json.dumps(asdict(self.me)).encode()[: self.RECORD_BYTES - 1] + b"\n"
        os.pwrite(self._fd, record.ljust(self.RECORD_BYTES), 0)

    def _holder(self) -> LockHolder | None:
        if not self._locked_by_someone():
            return None  # a record left by a holder that is gone
        for _ in range(20):  # the holder may be between flock and its first write
            try:
                data = json.loads(self.path.read_bytes().strip() or b"null")
                return LockHolder(**data) if data else None
            except FileNotFoundError:
                return None
            except (ValueError, TypeError):
                time.sleep(0.005)
        return None

    def _locked_by_someone(self) -> bool:
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_CLOEXEC)
        except FileNotFoundError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)
        return False


class PostgresRigLock(RigLock):
    """``pg_try_advisory_lock`` held by a connection of its own."""

    def __init__(self, url: str, rig_name: str, holder: LockHolder) -> None:
        super().__init__(rig_name, holder)
        digest = hashlib.sha256(self.key.encode()).digest()
        self.lock_key = (PG_LOCK_CLASS, int.from_bytes(digest[:4], "big") & 0x7FFFFFFF)
        # Keepalives both ways: the server drops a vanished holder's lock, and the holder
        # notices a lost server, within about half a minute.
        self._engine = sa.create_engine(
            url,
            poolclass=sa.pool.NullPool,
            connect_args={"keepalives": 1, "keepalives_idle": 10, "keepalives_interval": 5,
                          "keepalives_count": 3},
        )  # fmt: skip
        self._conn: sa.Connection | None = None

    def _connect(self) -> sa.Connection:
        conn = self._engine.connect().execution_options(isolation_level="AUTOCOMMIT")
        for name, value in (("tcp_keepalives_idle", 10), ("tcp_keepalives_interval", 5),
                            ("tcp_keepalives_count", 3)):  # fmt: skip
            conn.execute(sa.text("SELECT set_config(:n, :v, false)"), {"n": name, "v": str(value)})
        return conn

    def _try_acquire(self) -> bool:
        conn = self._connect()
        try:
            got = conn.execute(
                sa.text("SELECT pg_try_advisory_lock(:a, :b)"),
                {"a": self.lock_key[0], "b": self.lock_key[1]},
            ).scalar_one()
            if not got:
                conn.close()
                return False
            self._conn = conn
            self._publish()
            return True
        except BaseException:
            conn.close()
            raise

    def _release(self) -> None:
        if self._conn is not None:
            conn, self._conn = self._conn, None
            with contextlib.suppress(Exception):
                conn.execute(
                    sa.text("SELECT pg_advisory_unlock(:a, :b)"),
                    {"a": self.lock_key[0], "b": self.lock_key[1]},
                )
            conn.close()  # ending the connection drops the lock regardless
        self._engine.dispose()

    def _publish(self) -> None:
        assert self._conn is not None
        self._conn.execute(
            sa.text("SELECT set_config('application_name', :v, false)"),
            {"v": self.me.to_pg_name()},
        )

    def _holder(self) -> LockHolder | None:
        query = sa.text(
            "SELECT a.application_name, a.pid FROM pg_locks l "
            "JOIN pg_stat_activity a ON a.pid = l.pid "
            "WHERE l.locktype = 'advisory' AND l.granted AND l.objsubid = 2 "
            "AND l.classid = CAST(:a AS oid) AND l.objid = CAST(:b AS oid) "
            "AND l.database = (SELECT oid FROM pg_database WHERE datname = current_database())"
        )
        with self._engine.connect() as conn:
            row = conn.execute(query, {"a": self.lock_key[0], "b": self.lock_key[1]}).first()
        if row is None:
            return None
        return LockHolder.from_pg_name(row.application_name or "", row.pid)

    def check(self) -> None:
        """Make sure the lock is still held (the server may have restarted); take it again
        if it was lost, or raise :class:`RigInUse` if someone else took it meanwhile."""
        with self._guard:
            if not self.held or self._conn is None:
                return
            try:
                self._conn.execute(sa.text("SELECT 1"))
                return
            except Exception:
                with contextlib.suppress(Exception):
                    self._conn.close()
                self._conn = None
            if not self._try_acquire():
                self.held = False
                raise RigInUse(self.rig_name, self._holder())


class ProcessRigLock(RigLock):
    """A lock inside this process, for databases no other process can open."""

    _taken: ClassVar[dict[str, LockHolder]] = {}
    _registry_guard: ClassVar[threading.Lock] = threading.Lock()

    def _try_acquire(self) -> bool:
        with self._registry_guard:
            if self.key in self._taken:
                return False
            self._taken[self.key] = self.me
            return True

    def _release(self) -> None:
        with self._registry_guard:
            self._taken.pop(self.key, None)

    def _publish(self) -> None:
        with self._registry_guard:
            self._taken[self.key] = self.me

    def _holder(self) -> LockHolder | None:
        with self._registry_guard:
            return self._taken.get(self.key)


def _slug(key: str) -> str:
    short = re.sub(r"[^a-z0-9]+", "-", key).strip("-")[:40] or "rig"
    return f"{short}-{hashlib.sha256(key.encode()).hexdigest()[:8]}"


def _sqlite_file(url: sa.URL) -> Path | None:
    """The file of an SQLite URL, or None for an in-memory database."""
    database = url.database or ""
    if database.startswith("file:"):
        if "mode=memory" in database:
            return None
        database = database[5:].split("?", 1)[0]
    if not database or database == ":memory:":
        return None
    return Path(database).expanduser().resolve()


def rig_lock(database_url: str, rig_name: str, program: str | None = None) -> RigLock:
    """The lock on rig ``rig_name`` for processes sharing the database at ``database_url``."""
    holder = this_process(program)
    url = sa.make_url(database_url)
    backend = url.get_backend_name()
    if backend == "postgresql":
        return PostgresRigLock(database_url, rig_name, holder)
    if backend == "sqlite":
        path = _sqlite_file(url)
        if path is not None:
            lock_file = path.with_name(f"{path.name}.rig-{_slug(rig_key(rig_name))}.lock")
            return FileRigLock(lock_file, rig_name, holder)
    return ProcessRigLock(rig_name, holder)
