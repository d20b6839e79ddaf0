"""Two guards at the edge of the app, as plain ASGI middleware (streaming-safe).

``TokenFirst``: a request that can change something (any method but GET, HEAD, OPTIONS)
under ``/api/`` is answered 401 before its body is read or parsed when it carries no
valid bearer token (the service's or a named user's, ``api.http.identity``), so a malformed
body without a token is 401, not 422, and nothing of an unauthenticated body is ever
parsed. The emergency stop (``identity.NO_TOKEN_PATHS``) needs none. (The routes check the
token again, with the user's role.)

``SecurityHeaders``: every response says ``X-Frame-Options: DENY``, ``X-Content-Type-Options:
nosniff`` and a ``Content-Security-Policy`` with ``frame-ancestors 'none'``: the browser UI
keeps the token in localStorage, so no other site may frame it. The UI page itself gets the
full policy (``UI_POLICY``): scripts, styles, images and connections from this origin only
(plotly's inline styles and data/blob images for its figures and downloads).
"""

from __future__ import annotations

import json

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from api.http.auth import bearer_token, token_problem
from api.http.identity import NO_TOKEN_PATHS, user_for_token

#: Methods that only read: the routes' own token checks (and ``--open-read``) decide.
READ_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
#: The browser UI's policy (the page and everything it loads come from this origin).
UI_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
    "img-src 'self' data: blob:; connect-src 'self' blob:; font-src 'self' data:; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
#: Every other response (API answers, static files, the API docs with their own scripts).
DEFAULT_POLICY = "frame-ancestors 'none'"
#: The headers this middleware sets (any the app set are replaced).
_OURS = (b"content-security-policy", b"x-frame-options", b"x-content-type-options")
#: Paths that are the browser UI's page.
UI_PATHS = frozenset({"/", "/index.html"})


class TokenFirst:
    """401 for a state-changing ``/api/`` request without the right token, unread."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if (
            scope["type"] == "http"
            and scope["method"] not in READ_METHODS
            and scope["path"].startswith("/api/")
            and scope["path"].rstrip("/") not in NO_TOKEN_PATHS
        ):
            header = dict(scope["headers"]).get(b"authorization", b"").decode("latin-1")
            app = scope["app"]
            problem = token_problem(header, app.state.token)
            token = bearer_token(header)
            if problem is not None and not (token and await user_for_token(app, token)):
                await _unauthorized(send, problem)
                return
        await self.app(scope, receive, send)


async def _unauthorized(send: Send, detail: str) -> None:
    body = json.dumps({"detail": detail}).encode()
    headers = [
        (b"content-type", b"application/json"),
        (b"content-length", str(len(body)).encode()),
        (b"www-authenticate", b"Bearer"),
    ]
    await send({"type": "http.response.start", "status": 401, "headers": headers})
    await send({"type": "http.response.body", "body": body})


class SecurityHeaders:
    """Add the framing, sniffing and content-security headers to every HTTP response."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        policy = UI_POLICY if scope["path"] in UI_PATHS else DEFAULT_POLICY

        async def with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = [(k, v) for k, v in message.get("headers", []) if k.lower() not in _OURS]
                headers += [
                    (b"content-security-policy", policy.encode()),
                    (b"x-frame-options", b"DENY"),
                    (b"x-content-type-options", b"nosniff"),
                ]
                message = {**message, "headers": headers}
            await send(message)

        await self.app(scope, receive, with_headers)
