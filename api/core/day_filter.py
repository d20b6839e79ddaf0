"""The day window every stored-item list filters on (``since``, ``until``, ``tz``): one
declaration for the runs list and the results list, on both faces (their query parameters
and their ``rig`` options)."""

from __future__ import annotations

from datetime import UTC, datetime, tzinfo
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from daq.store.day_window import parse_moment, parse_tz, start_window

_DAY_HELP = "a day YYYY-MM-DD (local midnight in tz), 'today', 'yesterday' or an ISO 8601 date-time"


class DayFilter(BaseModel):
    """Items dated (a run's start, a result's making) within ``since`` … ``until``."""

    #: Built on first validation, not import: ``rig runs`` given no filter never builds
    #: its filter (``api.cli.options.request_from``), ~0.06 s of CPU (issue 33).
    model_config = ConfigDict(defer_build=True)

    since: Annotated[
        str | None,
        Field(max_length=64, description=f"On or after: {_DAY_HELP}."),
        Flag("--since", metavar="DAY"),
    ] = None
    until: Annotated[
        str | None,
        Field(max_length=64, description=f"On or before (a day: all of it): {_DAY_HELP}."),
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

    def window(self, default_zone: tzinfo | None = None) -> tuple[datetime | None, datetime | None]:
        """``since``/``until`` as aware datetimes in ``tz`` (else ``default_zone``, else
        UTC), a day's ``until`` to its end; ``ValueError`` naming ``since``, ``until`` or
        ``tz`` for text that is none of the allowed forms."""
        zone = parse_tz("tz", self.tz) or default_zone
        today = datetime.now(zone or UTC).date()
        return start_window(
            None if self.since is None else parse_moment("since", self.since, today=today),
            None if self.until is None else parse_moment("until", self.until, today=today),
            zone,
        )
