"""A POST over a raw socket whose body is fed only while the server has not answered: how
the body caps at the edge are pushed (tests/api/test_edge_limits.py, bench/edge_pressure.py)."""

from __future__ import annotations

import select
import socket
import time
from collections.abc import Iterator

CHUNK = 64 * 1024


def zeros(total: int) -> Iterator[bytes]:
    """A streamed body: ``total`` bytes in 64 KiB chunks, produced only when asked for."""
    for _ in range(total // CHUNK):
        yield b"0" * CHUNK


def feed_post(
    s: socket.socket,
    path: str,
    headers: dict[str, str],
    body: Iterator[bytes],
    *,
    chunked: bool,
    timeout_s: float = 60.0,
) -> int:
    """Send the head of ``POST path`` on the connected ``s``, then ``body`` (chunked
    transfer coding if ``chunked``) only while the server has not answered: until its
    first byte of answer, its closing the connection, the body's end or ``timeout_s``.
    Returns the body bytes handed to the socket; ``s`` is blocking again."""
    head = [f"POST {path} HTTP/1.1", "Host: 127.0.0.1", *(f"{k}: {v}" for k, v in headers.items())]
    if chunked:
        head.append("Transfer-Encoding: chunked")
    s.sendall(("\r\n".join(head) + "\r\n\r\n").encode())
    s.setblocking(False)
    sent = 0
    pending = b""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        readable, writable, _ = select.select([s], [s], [], 1.0)
        if readable:
            break
        if not writable:
            continue
        if not pending:
            chunk = next(body, None)
            if chunk is None:
                break
            pending = f"{len(chunk):x}\r\n".encode() + chunk + b"\r\n" if chunked else chunk
        try:
            n = s.send(pending)
        except (BlockingIOError, InterruptedError):
            continue
        except (BrokenPipeError, ConnectionResetError):
            break
        sent += n
        pending = pending[n:]
    s.setblocking(True)
    return sent
