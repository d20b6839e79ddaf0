"""The paging query parameters of every list route, declared once with their bounds.

``offset`` is 0 … ``MAX_OFFSET`` everywhere (a larger one is 422 naming it, never a
database overflow); ``limit`` is 1 … the list's page size (``PAGE_SIZES``).
"""

from __future__ import annotations

from typing import Annotated

from fastapi import Query

from api.core.jobs import LIST_LIMIT

#: The largest ``offset`` any list takes (a million rows skipped; 64-bit OFFSETs overflow).
MAX_OFFSET = 1_000_000
#: The most rows one page of each list holds.
PAGE_SIZES = {
    "runs": 1000,
    "jobs": LIST_LIMIT,
    "rig events": 500,
    "samples": 100_000,
    "results": 500,
}

Offset = Annotated[
    int,
    Query(ge=0, le=MAX_OFFSET, description=f"Skip this many of the newest (0 … {MAX_OFFSET})."),
]


def _limit(what: str) -> object:
    most = PAGE_SIZES[what]
    return Query(ge=1, le=most, description=f"At most this many {what} (1 … {most}).")


RunsLimit = Annotated[int, _limit("runs")]
JobsLimit = Annotated[int, _limit("jobs")]
EventsLimit = Annotated[int, _limit("rig events")]
SamplesLimit = Annotated[int, _limit("samples")]
ResultsLimit = Annotated[int, _limit("results")]
