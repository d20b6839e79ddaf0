"""Where a running ``rig serve`` listens, kept beside the token file (``api-address``,
mode 0600) so ``rig token --link`` links the port the service really took (``--port 0``,
``--port 8080``) without being told. The service writes it once it serves and removes it
when it stops; a file left by a killed service is ignored (its process is gone)."""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

from api.http.auth import token_path

#: The address ``rig token --link`` uses when no service says where it listens.
DEFAULT_HOST, DEFAULT_PORT = "127.0.0.1", 8000


def address_path() -> Path:
    """``api-address`` beside the token file."""
    return token_path().parent / "api-address"


def publish_address(host: str, port: int) -> None:
    """Say where this process serves (replacing the file at once: never half-written)."""
    path = address_path()
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    record = {"host": host, "port": port, "pid": os.getpid()}
    scratch = path.with_name(f".{path.name}.{os.getpid()}")
    fd = os.open(scratch, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(json.dumps(record) + "\n")
    os.replace(scratch, path)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def published_address() -> tuple[str, int] | None:
    """(host, port) of the running service, or None (none running, or a stale file)."""
    try:
        record = json.loads(address_path().read_text(encoding="utf-8"))
        host, port, pid = str(record["host"]), int(record["port"]), int(record["pid"])
    except (OSError, ValueError, TypeError, KeyError):
        return None
    if not 0 < port < 65536 or not _alive(pid):
        return None
    return host, port


def withdraw_address() -> None:
    """Remove the file if this process wrote it (never raises)."""
    path = address_path()
    with contextlib.suppress(OSError, ValueError, TypeError, KeyError):
        if int(json.loads(path.read_text(encoding="utf-8"))["pid"]) == os.getpid():
            path.unlink()
