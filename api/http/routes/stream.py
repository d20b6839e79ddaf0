"""The live stream: Server-Sent Events of samples and job events."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, Query
from fastapi.responses import StreamingResponse

from api.core.stream import sse_events
from api.http.app_codes import app_router
from api.http.deps import ServiceDep, require_read
from api.http.schemas import error_responses, file_response

router = app_router("/api", "stream")


@router.get(
    "/stream",
    dependencies=[Depends(require_read)],
    response_class=StreamingResponse,
    responses=file_response(
        {"text/event-stream": {}},
        "Events `sample` (one clock tick, SI), `job` (a job's new state), `guard` (the "
        "emergency stop and hold after a change through the service, to every client), "
        "`dropped` (how many events this client missed because it read too slowly).",
    )
    | error_responses(401, 422),
)
async def stream(
    service: ServiceDep,
    max_hz: Annotated[
        float | None,
        Query(gt=0, le=1000, description="Down-sample: at most this many samples per second."),
    ] = None,
    samples: Annotated[bool, Query(description="Send samples.")] = True,
    jobs: Annotated[bool, Query(description="Send job events.")] = True,
    max_events: Annotated[
        int | None, Query(ge=1, le=1_000_000, description="End after N events.")
    ] = None,
    max_s: Annotated[
        float | None, Query(gt=0, le=86_400, description="End after this many s.")
    ] = None,
) -> StreamingResponse:
    """Live samples and job events; a slow client loses its oldest events, never the clock."""
    events = sse_events(
        service.broadcaster,
        max_hz=max_hz,
        samples=samples,
        jobs=jobs,
        max_events=max_events,
        max_s=max_s,
    )
    return StreamingResponse(
        events,
        media_type="text/event-stream",
        headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"},
    )
