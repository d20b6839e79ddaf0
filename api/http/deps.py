"""What every route depends on: the service, the job runner, the store, the token checks.

All are ``async def``: they never block, and FastAPI would otherwise hop to a worker
thread for each of them on every request.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.core.jobs import JobRunner
from api.core.service import RigService, RigUnavailable
from api.http.auth import check_token
from daq.store import Store

bearer = HTTPBearer(
    auto_error=False,
    description="The service token: `rig token` prints it (or set RIG_API_TOKEN).",
)


async def get_service(request: Request) -> RigService:
    return request.app.state.service


async def get_runner(request: Request) -> JobRunner:
    return request.app.state.runner


async def get_store(request: Request) -> Store:
    store = request.app.state.service.store
    if store is None:
        raise RigUnavailable("the run database is not open")
    return store


async def require_write(request: Request, _: Credentials) -> None:
    """Every state-changing endpoint: the bearer token is required."""
    check_token(request, request.app.state.token)


async def require_read(request: Request, _: Credentials) -> None:
    """Read-only endpoints: the token is required unless the service runs ``--open-read``."""
    if not request.app.state.open_read:
        check_token(request, request.app.state.token)


ServiceDep = Annotated[RigService, Depends(get_service)]
RunnerDep = Annotated[JobRunner, Depends(get_runner)]
StoreDep = Annotated[Store, Depends(get_store)]
Credentials = Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]
