"""Which stored runs to list: one declaration for ``GET /api/runs`` (its query parameters,
``Annotated[RunFilter, Query()]``) and ``rig runs`` (its options, ``request_options``), so
a filter added here is on both faces, with the same name, range and help.
"""

from __future__ import annotations

from datetime import tzinfo
from typing import Annotated, Any, Literal

from pydantic import Field

from api.core.day_filter import DayFilter
from daq.procedures.flag import Flag
from daq.vocabulary import RunKind, RunStatus


class RunFilter(DayFilter):
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

    def store_filters(self, default_zone: tzinfo | None = None) -> dict[str, Any]:
        """The keyword arguments of ``Store.list_runs``/``count_runs`` (the day window as
        :meth:`DayFilter.window` gives it, in ``tz`` else ``default_zone`` else UTC)."""
        low, high = self.window(default_zone)
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
