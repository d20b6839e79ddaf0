"""Who a request acts as: the service's own token is the operator ``default`` (so a setup
with one shared token keeps working), any other token must be a named user's
(``rig user add``; only its SHA-256 is stored). Reads need any user (or ``--open-read``);
everything that starts, stops or changes something needs role ``operator`` (403 naming
the role otherwise) — except the emergency stop, which anyone may press."""

from __future__ import annotations

import asyncio
import hmac
from typing import Any

from fastapi import HTTPException, Request

from api.http.auth import presented_token
from daq.store.people_and_safety_log import User, UserRepository

#: The user the service's own token (``rig token``, ``RIG_API_TOKEN``) acts as.
DEFAULT_USER = User("default", "operator")
_MISSING = (
    "missing bearer token: send 'Authorization: Bearer <token>' (print it with 'rig token'; "
    "named users get theirs from 'rig user add')"
)
_WRONG = "wrong bearer token (print the right one with 'rig token', or ask for a named one)"


#: State-changing paths answered without a token (an edge check such as a token-first
#: middleware must let them through): the emergency stop only makes the rig safer.
NO_TOKEN_PATHS = frozenset({"/api/rig/emergency-stop"})


async def user_for_token(app: Any, token: str) -> User | None:
    """The user ``token`` belongs to in ``app`` (the service token: ``default``; else a
    named user, looked up by the token's SHA-256 off the event loop), or None."""
    if hmac.compare_digest(token.encode(), app.state.token.encode()):
        return DEFAULT_USER  # no database read for the common case
    store = app.state.service.store
    if store is None:
        return None
    return await asyncio.to_thread(UserRepository(store).by_token, token)


async def user_of(request: Request) -> User | None:
    """The user whose token the request carries; None without one; 401 for a wrong one."""
    token = presented_token(request)
    if token is None:
        return None
    user = await user_for_token(request.app, token)
    if user is None:
        raise HTTPException(401, _WRONG, headers={"WWW-Authenticate": "Bearer"})
    return user


async def known_user(request: Request) -> User:
    """The request's user; 401 without a token or with a wrong one."""
    user = await user_of(request)
    if user is None:
        raise HTTPException(401, _MISSING, headers={"WWW-Authenticate": "Bearer"})
    request.state.user = user
    return user


async def operator(request: Request) -> User:
    """The request's user if an operator; 401 without a valid token, 403 for a viewer."""
    user = await known_user(request)
    if not user.operator:
        raise HTTPException(
            403,
            f"user {user.name!r} has role {user.role}: starting, stopping or changing "
            "anything needs role operator",
        )
    return user


async def anyone(request: Request) -> User | None:
    """The request's user if its token is right, else None (never refuses): for the
    emergency stop, which only makes the rig safer."""
    try:
        return await user_of(request)
    except HTTPException:
        return None
