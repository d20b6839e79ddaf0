"""What every route depends on: the service, the job runner, the store, the token checks
(who the token belongs to: ``api.http.identity``).

All are ``async def``: they never block, and FastAPI would otherwise hop to a worker
thread for each of them on every request.
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Request
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from api.core.jobs import JobRunner
from api.core.service import RigService, RigUnavailable
from api.http.identity import known_user, operator
from daq.store import Store
from daq.store.people_and_safety_log import User

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


async def require_write(request: Request, _: Credentials) -> User:
    """Every state-changing endpoint: an operator's bearer token is required (403 for a
    viewer's)."""
    return await operator(request)


async def require_read(request: Request, _: Credentials) -> None:
    """Read-only endpoints: any user's token is required unless the service runs
    ``--open-read``."""
    if not request.app.state.open_read:
        await known_user(request)


ServiceDep = Annotated[RigService, Depends(get_service)]
RunnerDep = Annotated[JobRunner, Depends(get_runner)]
StoreDep = Annotated[Store, Depends(get_store)]
Credentials = Annotated[HTTPAuthorizationCredentials | None, Depends(bearer)]
#: The operator a state-changing request acts as (checked once per request: FastAPI caches
#: a dependency, so ``dependencies=[Depends(require_write)]`` and this share the check).
OperatorDep = Annotated[User, Depends(require_write)]
