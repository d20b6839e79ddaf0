"""The host's part of a lease: a lock the kernel drops when its holder dies.

Two kernel objects per device, both released by the kernel however the holder ends
(SIGKILL too), so nothing can leave a device locked:

* an **abstract unix socket** bound to a name made from the device (``\\0towrig-lease-…``):
  one per host (network namespace), whatever the user, the ``--db`` or the lock folder, and
  it has no file anyone could delete — this is what keeps a second driver out;
* an **``flock``** on ``<lock folder>/<device>.lock`` (mode 0600), which also holds the
  holder's description (JSON) for whoever is refused. The holder checks on every renewal
  that the path still names the file it locked; a deleted file is made again (the socket
  kept the device meanwhile), one locked by someone else is a lost lease. A folder deleted
  under the holder (``rm -rf "$RIG_LOCK_DIR"``) is made again too; while it cannot be, the
  socket alone keeps the device and the next renewal tries again — the file is a
  description and a guard across namespaces, the socket is the lock.

Messages name a lock file by its name in the lock folder, never by its absolute path (they
reach ``/api/rig``, a job's error and a run's reason).

The lock folder is ``$RIG_LOCK_DIR`` if set, else ``/run/towrig`` if it exists and is
writable (an administrator may create it), else ``/tmp/towrig-locks`` (created mode 1777
like ``/tmp``, so every user's processes share it). It does not depend on ``--db``.
"""

from __future__ import annotations

import errno
import fcntl
import json
import logging
import os
import re
import socket
import time
from dataclasses import asdict
from pathlib import Path

from daq.rig_lock.holder import LockHolder
from daq.rig_lock.leased_devices import Device

log = logging.getLogger(__name__)

LOCK_DIR_ENV = "RIG_LOCK_DIR"
SYSTEM_LOCK_DIR = Path("/run/towrig")
SHARED_LOCK_DIR = Path("/tmp/towrig-locks")
#: The description is written padded to this size, in place, so a reader never sees the
#: file empty between a truncate and a write.
RECORD_BYTES = 1024


def lock_dir() -> Path:
    """Where this host's lock files are (see the module docstring)."""
    if configured := os.environ.get(LOCK_DIR_ENV, "").strip():
        return Path(configured)
    if SYSTEM_LOCK_DIR.is_dir() and os.access(SYSTEM_LOCK_DIR, os.W_OK | os.X_OK):
        return SYSTEM_LOCK_DIR
    return SHARED_LOCK_DIR


def _ensure_dir(path: Path) -> None:
    if path.is_dir():
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        path.mkdir()
    except FileExistsError:
        return  # made meanwhile by another process (maybe another user's)
    if path == SHARED_LOCK_DIR:
        os.chmod(path, 0o1777)  # every user's processes make their files here (sticky)


class HostLock:
    """The host lock on one device; ``acquire`` returns False when another process holds it."""

    def __init__(self, device: Device, folder: Path | None = None) -> None:
        self.device = device
        digest = device.digest()
        self.socket_name = b"\0towrig-lease-" + digest.hex()[:40].encode()
        slug = re.sub(r"[^a-z0-9]+", "-", device.key.casefold()).strip("-")[:48]
        self.path = (folder or lock_dir()) / f"{slug}-{digest.hex()[:10]}.lock"
        self._sock: socket.socket | None = None
        self._fd: int | None = None

    # -- holding ------------------------------------------------------------------------
    def acquire(self, holder: LockHolder) -> bool:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        try:
            sock.bind(self.socket_name)
        except OSError as err:
            sock.close()
            if err.errno == errno.EADDRINUSE:
                return False
            raise
        try:
            _ensure_dir(self.path.parent)
            fd = self._lock_file()
        except BaseException:
            sock.close()
            raise
        if fd is None:  # locked by a process that cannot see our socket (another namespace)
            sock.close()
            return False
        self._sock, self._fd = sock, fd
        self.publish(holder)
        return True

    def _lock_file(self) -> int | None:
        """Open, ``flock`` and check that the path still names the file locked (a holder
        releasing unlinks it); None when someone else holds the ``flock``."""
        for _ in range(50):
            try:
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o600)
            except PermissionError:  # another user's leftover in the shared folder?
                suffix = f"-uid{os.getuid()}"
                if self.path.stem.endswith(suffix) or not self.path.exists():
                    raise  # the folder itself refuses us
                self.path = self.path.with_name(f"{self.path.stem}{suffix}.lock")
                continue
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                os.close(fd)
                return None
            if self._names(fd):
                return fd
            os.close(fd)  # unlinked or replaced after we opened it: try the new one
        raise OSError(f"cannot lock {self.path.name}: it keeps being replaced")

    def _names(self, fd: int) -> bool:
        """Whether the lock path names the file open as ``fd``."""
        try:
            on_disk = os.stat(self.path)
        except (FileNotFoundError, NotADirectoryError):  # gone, or its folder replaced
            return False
        mine = os.fstat(fd)
        return (on_disk.st_dev, on_disk.st_ino) == (mine.st_dev, mine.st_ino)

    def verify(self, holder: LockHolder) -> str | None:
        """A renewal: None while the device is ours; a file (or its whole folder) deleted
        under us is made again — while it cannot be, the socket keeps the device and the
        next renewal tries again; a file someone else locked is why it is lost."""
        if self._fd is None or self._names(self._fd):
            return None
        try:
            _ensure_dir(self.path.parent)
            fd = self._lock_file()
        except OSError as err:
            log.warning(
                "rig lock: cannot make %s again in the lock folder (%s); the device stays "
                "held by its socket",
                self.path.name,
                err.strerror or type(err).__name__,
            )
            return None
        if fd is None:
            return f"its lock file {self.shown} was replaced and locked by another process"
        os.close(self._fd)
        self._fd = fd
        self.publish(holder)
        return None

    @property
    def shown(self) -> str:
        """The lock file as messages name it: its name in the lock folder, no host path."""
        return f"{self.path.name} (in the lock folder)"

    def publish(self, holder: LockHolder) -> None:
        if self._fd is not None:
            record = json.dumps(asdict(holder)).encode()[: RECORD_BYTES - 1] + b"\n"
            os.pwrite(self._fd, record.ljust(RECORD_BYTES), 0)

    def release(self) -> None:
        """Unlink the lock file (while still holding it) and let go. Never raises."""
        fd, sock, self._fd, self._sock = self._fd, self._sock, None, None
        if fd is not None:
            try:
                if self._names(fd):
                    os.unlink(self.path)
            except OSError:
                pass
            os.close(fd)
        if sock is not None:
            sock.close()

    # -- looking ------------------------------------------------------------------------
    def taken(self) -> bool:
        """Whether some process on this host holds the device (probes the socket)."""
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        probe.setblocking(False)
        try:
            probe.sendto(b"", self.socket_name)
        except (ConnectionRefusedError, FileNotFoundError):
            return self._file_locked()
        except BlockingIOError:  # bound, its queue full of earlier probes
            return True
        finally:
            probe.close()
        return True

    def _file_locked(self) -> bool:
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_CLOEXEC)
        except OSError:
            return False
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
        finally:
            os.close(fd)
        return False

    def holder(self) -> LockHolder | None:
        """The description the holder wrote (None if unreadable or still being written)."""
        for _ in range(20):  # the holder may be between its lock and its first write
            try:
                data = json.loads(self.path.read_bytes().strip() or b"null")
                return LockHolder(**data) if data else None
            except OSError:
                return None
            except (ValueError, TypeError):
                time.sleep(0.005)
        return None
