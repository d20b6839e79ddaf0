"""One rig, one driver: a lease on the rig's devices, held across processes and hosts.

Every process that opens a rig's devices (``rig serve``, ``rig tow``, …) first takes the
lease on the devices its rig file points at (``daq.rig_lock.leased_devices``: PLC address and
unit, serial ports — not the rig's name, not the database), before any device is touched,
and holds it until its session is closed. A second process is refused at once, naming the
device and who holds it::

    rig 'BENBAM tow tank' (PLC tcp 10.0.0.5:502 unit 1) is in use by `rig serve` pid 1234
    on host lab-pc since 2026-11-23 16:02:11 (tow 24.5 N, run 3f2a9c1b)

The lease has two parts:

* **on this host**, always (``daq.rig_lock.local``): kernel-released locks found by every
  process of the host whatever ``--db`` it uses, and that deleting a file cannot break;
* **in PostgreSQL**, when the process records there (``daq.rig_lock.postgres``): advisory
  locks on one connection, so processes on other hosts sharing the database see it too.

It is **renewed** every ``RENEW_INTERVAL_S`` by a thread of its own (the PostgreSQL
connection queried, the lock files checked). A renewal that fails is a **lost lease**:
``on_lost(reason)`` is called once, from that thread, with a reason beginning
``rig lock lost`` (naming a lock file by its name, never a host path) —
:class:`daq.session.RigSession` treats it like a lost PLC (thrusters to
zero, brakes on, the run aborted naming the lost lock, devices released).
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import sqlalchemy as sa

from daq.rig_lock.holder import (
    LOCK_LOST,
    LockHolder,
    RigInUse,
    RigLockError,
    program_name,
    this_process,
)
from daq.rig_lock.leased_devices import Device, rig_devices
from daq.rig_lock.local import LOCK_DIR_ENV, HostLock, lock_dir
from daq.rig_lock.postgres import PgLease

if TYPE_CHECKING:
    from daq.config import RigConfig

log = logging.getLogger(__name__)

#: How often the lease is renewed, s (a loss is seen at most this long after it happened).
RENEW_INTERVAL_S = 0.2

__all__ = [
    "LOCK_LOST",
    "RENEW_INTERVAL_S",
    "Device",
    "LockHolder",
    "RigInUse",
    "RigLease",
    "RigLockError",
    "RigLockLost",
    "lock_dir",
    "program_name",
    "rig_devices",
    "rig_lock",
    "this_process",
]


class RigLockLost(RuntimeError):
    """The lease was lost while held (``check`` after the loss)."""


class RigLease:
    """The lease on ``devices`` (host locks, plus PostgreSQL advisory locks when
    ``database_url`` is a PostgreSQL URL); ``acquire`` raises :class:`RigInUse`."""

    def __init__(
        self,
        rig_name: str,
        devices: list[Device] | Callable[[], list[Device]],
        holder: LockHolder,
        database_url: str | None = None,
    ) -> None:
        self.rig_name = rig_name
        self._devices_of = devices if callable(devices) else (lambda: devices)
        self._database_url = database_url
        self.me = holder
        #: Filled by ``prepare`` (naming a device may resolve a host name: not on a loop).
        self.devices: list[Device] = []
        self.host_locks: list[HostLock] = []
        self.pg: PgLease | None = None
        #: Called once, from the renewal thread, when the lease is lost.
        self.on_lost: Callable[[str], object] | None = None
        #: Why the lease was lost (None while held or never taken).
        self.lost: str | None = None
        self.held = False
        self._guard = threading.Lock()
        self._stop = threading.Event()
        self._watcher: threading.Thread | None = None

    def prepare(self) -> None:
        """Name the devices and make their locks (once; ``acquire`` does it first)."""
        if self.devices:
            return
        self.devices = self._devices_of()
        self.host_locks = [HostLock(d) for d in self.devices]
        url = self._database_url
        if url and sa.make_url(url).get_backend_name() == "postgresql":
            self.pg = PgLease(url, self.devices)

    def acquire(self) -> None:
        """Take every device (host first, then PostgreSQL) and start renewing."""
        self.prepare()
        with self._guard:
            if self.held:
                return
            self.me = replace(self.me, since=time.time(), activity=None)
            taken: list[HostLock] = []
            try:
                for lock in self.host_locks:
                    try:
                        got = lock.acquire(self.me)
                    except OSError as err:
                        why = err.strerror or str(err)
                        raise RigLockError(
                            f"cannot take the rig lock: its lock folder cannot be used "
                            f"({why}; set {LOCK_DIR_ENV} to a folder every process driving "
                            "the rig can write)"
                        ) from err
                    if not got:
                        raise RigInUse(self.rig_name, lock.holder(), str(lock.device))
                    taken.append(lock)
                if self.pg is not None and (device := self.pg.acquire(self.me)) is not None:
                    raise RigInUse(self.rig_name, self.pg.holder_of(device), str(device))
            except BaseException:
                for lock in reversed(taken):
                    lock.release()
                raise
            self.held, self.lost = True, None
            self._stop.clear()
            self._watcher = threading.Thread(target=self._watch, name="rig-lease", daemon=True)
            self._watcher.start()

    def release(self) -> None:
        """Stop renewing and give every device back (never raises)."""
        self._stop.set()
        watcher, self._watcher = self._watcher, None
        if watcher is not None and watcher is not threading.current_thread():
            watcher.join(5)
        with self._guard:
            self.held = False
            if self.pg is not None:
                self.pg.release()
            for lock in reversed(self.host_locks):
                lock.release()

    def check(self) -> None:
        """Raise :class:`RigLockLost` if the lease was lost."""
        if self.lost is not None:
            raise RigLockLost(self.lost)

    def set_activity(self, activity: str | None) -> None:
        """Say what this holder is doing (shown to whoever is refused)."""
        with self._guard:
            self.me = replace(self.me, activity=activity)
            if self.held:
                for lock in self.host_locks:
                    with contextlib.suppress(OSError):
                        lock.publish(self.me)
                if self.pg is not None:
                    self.pg.publish(self.me)

    def holder(self) -> LockHolder | None:
        """Who holds the rig's first taken device now (``None`` when all are free)."""
        if self.held:
            return self.me
        self.prepare()
        for lock in self.host_locks:
            if lock.taken():
                return lock.holder()
        if self.pg is not None:
            for device in self.devices:
                if (who := self.pg.holder_of(device)) is not None:
                    return who
        return None

    def __enter__(self) -> RigLease:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()

    # -- renewal --------------------------------------------------------------------------
    def _watch(self) -> None:
        while not self._stop.wait(RENEW_INTERVAL_S):
            reason = self._renew()
            if reason is None:
                continue
            if self._stop.is_set():  # released meanwhile: not a loss
                return
            self.lost = f"{LOCK_LOST}: {reason}"
            log.error("%s", self.lost)
            if self.on_lost is not None:
                try:
                    self.on_lost(self.lost)
                except Exception:
                    log.exception("rig lease: on_lost failed")
            return

    def _renew(self) -> str | None:
        with self._guard:
            if not self.held:
                return None
            for lock in self.host_locks:
                try:
                    why = lock.verify(self.me)
                except OSError as err:
                    why = f"its lock file {lock.shown} cannot be checked ({err.strerror})"
                if why is not None:
                    return f"{lock.device}: {why}"
        if self.pg is not None:
            return self.pg.renew()
        return None


def rig_lock(database_url: str | None, rig: RigConfig, program: str | None = None) -> RigLease:
    """The lease on ``rig``'s devices for a process recording to ``database_url``
    (``program`` names this process to whoever is refused; default ``rig <command>``)."""
    return RigLease(rig.rig.name, lambda: rig_devices(rig), this_process(program), database_url)
