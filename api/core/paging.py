"""The page of every list, declared once: one model per list whose routes take it as query
parameters (``Annotated[RunsPage, Query()]``) and whose ``rig`` command takes it as options
(``request_options``), so ``limit`` and ``offset`` have one range, one default and one help
on both faces (a value outside is 422 over HTTP, exit 2 on the command line, naming it).

``offset`` is 0 … :data:`MAX_OFFSET` on every list (never a database overflow); ``limit`` is
1 … the list's page size.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field
from pydantic.fields import FieldInfo

from daq.procedures.flag import Flag

#: The largest ``offset`` any list takes (a million rows skipped; 64-bit OFFSETs overflow).
MAX_OFFSET = 1_000_000
#: The most rows one page of each list holds (runs: the whole table of a busy lab's year,
#: which ``rig runs`` prints in ~1.4 s of CPU).
MOST_RUNS, MOST_JOBS, MOST_RESULTS = 10_000, 500, 500
#: ``limit``, when not given, on every list with a default page (rows).
DEFAULT_LIMIT = 100
#: The flags of the page's two fields.
_LIMIT, _OFFSET = Flag("--limit", metavar="N"), Flag("--offset", metavar="N")


def _limit(what: str, most: int) -> FieldInfo:
    """``limit``'s range and help on the list of ``what``: 1 … ``most``."""
    return Field(ge=1, le=most, description=f"At most this many {what} (1 … {most}).")


class _Deferred(BaseModel):
    """A page model built on first validation, not import: ``rig runs`` imports this module
    for its page and need not build the others' (~0.01 s of CPU each, and the first build
    loads pydantic's plugin entry points, ~0.05 s)."""

    model_config = ConfigDict(defer_build=True)


class _Page(_Deferred):
    """At most ``limit`` (each list's own range, declared by its subclass), after skipping
    ``offset`` of the newest."""

    #: Stands first (``--limit`` before ``--offset``); each subclass gives its range.
    limit: int = DEFAULT_LIMIT
    offset: Annotated[
        int,
        Field(ge=0, le=MAX_OFFSET, description=f"Skip this many of the newest (0 … {MAX_OFFSET})."),
        _OFFSET,
    ] = 0


class RunsPage(_Page):
    """A page of ``GET /api/runs`` and ``rig runs``."""

    limit: Annotated[int, _limit("runs", MOST_RUNS), _LIMIT] = DEFAULT_LIMIT


class JobsPage(_Page):
    """A page of ``GET /api/jobs`` and ``rig jobs``."""

    limit: Annotated[int, _limit("jobs", MOST_JOBS), _LIMIT] = DEFAULT_LIMIT


class ResultsPage(_Page):
    """A page of ``GET /api/results`` and ``rig results``."""

    limit: Annotated[int, _limit("results", MOST_RESULTS), _LIMIT] = DEFAULT_LIMIT


class EventsPage(_Deferred):
    """The newest entries of ``GET /api/rig/events`` (the rig's safety log; no command)."""

    limit: Annotated[int, _limit("rig events", 500)] = 50


class SamplesPage(_Deferred):
    """How many samples one page of ``GET /api/runs/{id}/samples`` holds (no command)."""

    limit: Annotated[int, _limit("samples", 100_000)] = 1000
