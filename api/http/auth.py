"""The API's bearer token: where it comes from and how a request proves it has it.

The token is ``$RIG_API_TOKEN`` when set; otherwise it is generated once and kept in
``api-token`` next to the default database (``~/.local/share/towrig/api-token``,
mode 0600), so ``rig serve`` and ``rig token`` agree across restarts.
"""

from __future__ import annotations

import hmac
import os
import secrets
import stat
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # ``rig token`` reads the token without importing the web stack
    from fastapi import Request

from daq.data_dir import default_database_path

TOKEN_ENV = "RIG_API_TOKEN"


def token_path() -> Path:
    """Where a generated token is kept: ``api-token`` beside the default database."""
    return default_database_path().parent / "api-token"


def load_or_create_token(path: Path | None = None) -> str:
    """``$RIG_API_TOKEN``, else the token stored at ``path`` (created, mode 0600, if absent)."""
    from_env = os.environ.get(TOKEN_ENV, "").strip()
    if from_env:
        return from_env
    path = path or token_path()
    if path.exists():
        text = path.read_text(encoding="utf-8").strip()
        if text:
            return text
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)  # the database's folder too
    token = secrets.token_urlsafe(32)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(token + "\n")
    return token


def token_file_warning(path: Path | None = None) -> str | None:
    """A one-line warning (with the fix) when the token file is readable or writable by
    group or others; ``None`` when it is private, absent, or the token comes from the env."""
    if os.environ.get(TOKEN_ENV, "").strip():
        return None
    path = path or token_path()
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
    except OSError:
        return None
    if not mode & 0o077:
        return None
    return (
        f"warning: token file {path} has mode {mode:04o}: other users can read the API "
        f"token; fix: chmod 600 {path}"
    )


def presented_token(request: Request) -> str | None:
    """The token of an ``Authorization: Bearer <token>`` header, if any."""
    return bearer_token(request.headers.get("authorization", ""))


def bearer_token(header: str) -> str | None:
    scheme, _, value = header.partition(" ")
    if scheme.lower() == "bearer" and value.strip():
        return value.strip()
    return None


def token_problem(authorization: str, expected: str) -> str | None:
    """Why an ``Authorization`` header value does not prove ``expected`` (constant-time
    comparison), or None when it does."""
    given = bearer_token(authorization)
    if given is None:
        return (
            "missing bearer token: send 'Authorization: Bearer <token>' (print it with 'rig token')"
        )
    if not hmac.compare_digest(given.encode(), expected.encode()):
        return "wrong bearer token (print the right one with 'rig token')"
    return None


def check_token(request: Request, expected: str) -> None:
    """Raise 401 unless the request carries ``expected`` (constant-time comparison)."""
    from fastapi import HTTPException

    problem = token_problem(request.headers.get("authorization", ""), expected)
    if problem is not None:
        raise HTTPException(401, problem, headers={"WWW-Authenticate": "Bearer"})
