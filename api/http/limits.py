"""Request-body caps at the edge, before any parsing or token check.

``BodyLimit`` is plain ASGI middleware: a request whose ``Content-Length`` is over its
route's cap is answered 413 at once (the body is never read); a body without one
(chunked) is counted as the app reads it and refused with 413 as soon as it passes the
cap. Caps per route class: JSON bodies ``JSON_BODY_LIMIT``; the CSV import the app's
``max_upload_bytes`` (``UPLOAD_PATHS``).
"""

from __future__ import annotations

import json

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

#: Largest JSON request body (bytes): the biggest legitimate one, a 100-step sequence, is
#: ~20 KiB.
JSON_BODY_LIMIT = 64 * 1024
#: Largest CSV upload (bytes) by default: ~10⁶ rows of ``t,position``.
UPLOAD_BODY_LIMIT = 64 * 1024 * 1024
#: Routes that take a CSV body (the larger cap).
UPLOAD_PATHS = frozenset({"/api/runs/import", "/api/calibrations/import"})


def _too_large(limit: int, size: int | None = None) -> str:
    what = f"request body of {size} bytes" if size is not None else "request body"
    return f"{what} is over this endpoint's {limit}-byte limit"


class BodyLimit:
    """Refuse request bodies over ``json_limit`` (``upload_limit`` on ``UPLOAD_PATHS``)."""

    def __init__(self, app: ASGIApp, *, json_limit: int, upload_limit: int) -> None:
        self.app = app
        self.json_limit = json_limit
        self.upload_limit = upload_limit

    def limit_for(self, path: str) -> int:
        return self.upload_limit if path.rstrip("/") in UPLOAD_PATHS else self.json_limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.limit_for(scope["path"])
        declared = dict(scope["headers"]).get(b"content-length")
        if declared is not None:
            size = int(declared) if declared.isdigit() else None
            if size is None:
                await _reply(send, 400, f"Content-Length {declared[:40]!r} is not a number")
                return
            if size > limit:
                await _reply(send, 413, _too_large(limit, size))
                return
        received = 0

        async def counted() -> Message:
            nonlocal received
            message = await receive()
            if message["type"] == "http.request":
                received += len(message.get("body", b""))
                if received > limit:
                    raise HTTPException(413, _too_large(limit))
            return message

        await self.app(scope, counted, send)


async def _reply(send: Send, status: int, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        (b"connection", b"close"),
    ]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})
