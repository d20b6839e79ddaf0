"""People and safety: who am I, acknowledging an emergency stop, holding the rig.

``POST /api/estop/ack`` (an operator, named in the safety log) lets the rig move again
after an emergency stop. ``POST /api/rig/hold`` with a reason holds the rig for its
holder: starts by anyone else are refused with 423 naming the holder and why, until the
holder releases it (``POST /api/rig/release``) or another operator overrides
(``{"override": true}``, logged as such). ``GET /api/rig/events`` is the safety log.
"""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import Depends, Query, Request
from pydantic import BaseModel, Field

from api.core.job_model import iso_time
from api.core.paging import EventsPage
from api.core.people import AckIn, HoldIn, ReleaseIn
from api.core.rig_guard import RigGuard, published_state
from api.http.app_codes import app_router
from api.http.deps import OperatorDep, ServiceDep, require_read
from api.http.identity import known_user
from api.http.schemas import error_responses
from daq.store.people_and_safety_log import User

router = app_router("/api", "people")


class GuardOut(BaseModel):
    estop: dict[str, Any] | None = Field(
        None, description="The emergency stop not yet acknowledged: {by, at, message}."
    )
    hold: dict[str, Any] | None = Field(
        None, description="Who holds the rig and why: {by, at, message}."
    )


class UserOut(BaseModel):
    name: str
    role: str


class RigEventOut(BaseModel):
    t_wall: str
    kind: str = Field(description="estop, estop_ack, hold or release")
    user: str | None = Field(None, description="Who (null: an emergency stop without token).")
    message: str


async def _guard(service, change) -> dict[str, Any]:
    """Make ``change`` to the rig's guard; its new state answers and goes to the stream."""
    guard = RigGuard.of(service)
    await asyncio.to_thread(change, guard)
    return await asyncio.to_thread(published_state, service, guard)


@router.get("/whoami", response_model=UserOut, responses=error_responses(401))
async def whoami(user: Annotated[User, Depends(known_user)]) -> dict:
    """The user the request's token belongs to and its role (``default``: the service's own
    token, an operator)."""
    return {"name": user.name, "role": user.role}


@router.post("/estop/ack", response_model=GuardOut, responses=error_responses(401, 403, 409, 503))
async def acknowledge_estop(
    service: ServiceDep, user: OperatorDep, body: AckIn | None = None
) -> dict:
    """Acknowledge the emergency stop (an operator, named in the safety log): the rig
    takes starts again. 409 when no stop is latched."""
    note = body.note if body is not None else ""
    return await _guard(service, lambda g: g.acknowledge(user, note))


@router.post(
    "/rig/hold", response_model=GuardOut, responses=error_responses(401, 403, 422, 423, 503)
)
async def hold_rig(service: ServiceDep, user: OperatorDep, body: HoldIn) -> dict:
    """Hold the rig for local work: until released, starts by anyone else are refused
    (423 naming the holder and the reason). Holding it again replaces the reason."""
    return await _guard(service, lambda g: g.take_hold(user, body.reason))


@router.post(
    "/rig/release", response_model=GuardOut, responses=error_responses(401, 403, 409, 423, 503)
)
async def release_rig(
    service: ServiceDep, user: OperatorDep, body: ReleaseIn | None = None
) -> dict:
    """Release the hold: its holder, or another operator with ``override`` (logged)."""
    override = body.override if body is not None else False
    return await _guard(service, lambda g: g.release(user, override))


@router.get(
    "/rig/events",
    response_model=list[RigEventOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 503),
)
async def rig_events(
    request: Request,
    service: ServiceDep,
    page: Annotated[EventsPage, Query()],
) -> list[dict]:
    """The rig's safety log, newest first: emergency stops, acknowledgements, holds and
    releases, each naming who."""
    events = await asyncio.to_thread(RigGuard.of(service).log.recent, page.limit)
    return [
        {
            "t_wall": iso_time(e["t_wall"]),
            "kind": e["kind"],
            "user": e["user_name"],
            "message": e["message"],
        }
        for e in events
    ]
