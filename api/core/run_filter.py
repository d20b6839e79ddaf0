"""Which stored runs to list: one declaration for ``GET /api/runs`` (its query parameters,
``Annotated[RunFilter, Query()]``) and ``rig runs`` (its options, ``request_options``), so
a filter added here is on both faces, with the same name, range and help.
"""

from __future__ import annotations

from datetime import UTC, datetime, tzinfo
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field

from daq.procedures.procedure_request import Flag
from daq.store.day_window import parse_moment, parse_tz, start_window
from daq.vocabulary import RunKind, RunStatus

_DAY_HELP = "a day YYYY-MM-DD (local midnight in tz), 'today', 'yesterday' or an ISO 8601 date-time"


class RunFilter(BaseModel):
    """Every filter optional; the runs listed match all those given."""

    kind: Annotated[
        RunKind | None, Field(description="Only runs of this kind."), Flag("--kind")
    ] = None
    status: Annotated[
        RunStatus | None, Field(description="Only runs that ended so."), Flag("--status")
    ] = None
    drive: Annotated[
        Literal["weight", "thrusters", "none"] | None,
        Field(description="What moved the vehicle (none: nothing, e.g. a pendulum)."),
        Flag("--drive"),
    ] = None
    source: Annotated[
        Literal["recorded", "imported"] | None,
        Field(description="Recorded here or imported."),
        Flag("--source"),
    ] = None
    vehicle: Annotated[
        str | None,
        Field(max_length=200, description="Only runs of this vehicle."),
        Flag("--vehicle"),
    ] = None
    tag: Annotated[
        str | None,
        Field(max_length=40, description="Only runs with this tag."),
        Flag("--tag", metavar="TAG"),
    ] = None
    search: Annotated[
        str | None,
        Field(
            max_length=200,
            description="Text in the metadata (operator, notes, tags, free keys), the vehicle, "
            "the imported file's name or the start of the run id.",
        ),
        Flag("--search", metavar="TEXT"),
    ] = None
    since: Annotated[
        str | None,
        Field(max_length=64, description=f"Started on or after: {_DAY_HELP}."),
        Flag("--since", metavar="DAY"),
    ] = None
    until: Annotated[
        str | None,
        Field(max_length=64, description=f"Started on or before (a day: all of it): {_DAY_HELP}."),
        Flag("--until", metavar="DAY"),
    ] = None
    tz: Annotated[
        str | None,
        Field(
            max_length=64,
            description="Time zone of since/until days and of date-times without an offset: "
            "IANA name (Europe/Oslo), UTC or ±HH:MM. Default: UTC over HTTP, this computer's "
            "zone in the CLI.",
        ),
        Flag("--tz", metavar="ZONE"),
    ] = None

    def store_filters(self, default_zone: tzinfo | None = None) -> dict[str, Any]:
        """The keyword arguments of ``Store.list_runs``/``count_runs``: ``since``/``until``
        as the window's aware datetimes in ``tz`` (else ``default_zone``, else UTC);
        ``ValueError`` naming ``since``, ``until`` or ``tz`` for text that is none of
        the allowed forms."""
        zone = parse_tz("tz", self.tz) or default_zone
        today = datetime.now(zone or UTC).date()
        low, high = start_window(
            None if self.since is None else parse_moment("since", self.since, today=today),
            None if self.until is None else parse_moment("until", self.until, today=today),
            zone,
        )
        return {
            "kind": None if self.kind is None else str(self.kind),
            "status": None if self.status is None else str(self.status),
            "drive": self.drive,
            "source": self.source,
            "vehicle": self.vehicle,
            "tag": self.tag,
            "search": self.search,
            "since": low,
            "until": high,
        }
