"""Static assets over the wire: the interactive API docs served from an installed package
(no CDN, so ``/docs`` and ``/redoc`` work offline) and gzip for the big bundles.

``fastapi-offline`` ships Swagger UI and ReDoc and mounts them at ``DOCS_ASSETS_URL``;
``compress_static`` gzips only the UI's and the docs' files, never API responses or the
event stream. plotly.js, which every page that draws a plot loads (the basic bundle: 1.2 MB,
about 0.4 MB gzipped), is compressed once per process and version of the file (``bundle``).
"""

from __future__ import annotations

import functools
import gzip
from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi.responses import FileResponse, Response
from fastapi_offline import FastAPIOffline
from starlette.middleware.gzip import GZipMiddleware
from starlette.types import ASGIApp, Receive, Scope, Send

#: Where the Swagger UI / ReDoc files are served from.
DOCS_ASSETS_URL = "/static-offline-docs"
#: Paths whose responses are gzipped when the client accepts it.
COMPRESSED_PREFIXES = ("/static/", f"{DOCS_ASSETS_URL}/")
#: zlib level: 6 compressed plotly.js to within 2 % of level 9 in a third of the time.
COMPRESS_LEVEL = 6


def app_with_offline_docs(**kwargs: Any) -> FastAPI:
    """``FastAPI(**kwargs)`` with ``/docs`` and ``/redoc`` using locally served assets."""
    return FastAPIOffline(static_url=DOCS_ASSETS_URL, **kwargs)


@functools.lru_cache(maxsize=4)
def _gzipped(path: Path, mtime_ns: int, size: int) -> bytes:
    """``path``'s bytes gzipped; the cache key holds the file's version (mtime, size)."""
    return gzip.compress(path.read_bytes(), COMPRESS_LEVEL, mtime=0)


def bundle(path: Path, media_type: str, accept_encoding: str) -> Response:
    """A big static file: gzipped from memory to a client whose ``Accept-Encoding`` names
    gzip (compressed once per file version; the middleware passes an encoded response
    through), else the file itself. Both carry the file's ``ETag`` and ``Last-Modified``."""
    stat = path.stat()
    plain = FileResponse(path, media_type=media_type, stat_result=stat)
    if "gzip" not in accept_encoding:  # the test GZipMiddleware applies to the other files
        return plain
    body = _gzipped(path, stat.st_mtime_ns, stat.st_size)
    validators = {k: plain.headers[k] for k in ("etag", "last-modified")}
    headers = validators | {"Content-Encoding": "gzip", "Vary": "Accept-Encoding"}
    return Response(body, media_type=media_type, headers=headers)


class _StaticGZip:
    """GZip for ``COMPRESSED_PREFIXES`` only; everything else passes through untouched."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app
        self.gzip = GZipMiddleware(app, minimum_size=1024, compresslevel=COMPRESS_LEVEL)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and scope["path"].startswith(COMPRESSED_PREFIXES):
            await self.gzip(scope, receive, send)
        else:
            await self.app(scope, receive, send)


def compress_static(app: FastAPI) -> None:
    """Serve the static bundles gzipped to clients that accept it."""
    app.add_middleware(_StaticGZip)
