"""Finding runs: the filters of a run list (kind, status, vehicle, drive, source, tag,
free text, start time) as one WHERE clause, shared by the list and its total."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime

import sqlalchemy as sa

from daq.store import checks
from daq.store.run_metadata import check_tag
from daq.store.schema import RUN_DRIVES, RUN_SOURCES, RUN_STATUSES, run_tags, vehicles
from daq.store.schema import runs as runs_t
from daq.vocabulary import FIXED_DRIVE

#: Longest free-text search accepted.
MAX_SEARCH_CHARS = 200


def drive_of(kind: str, parameters: dict) -> str | None:
    """What moved the vehicle in a run: its ``drive`` parameter, else its kind's one drive
    (``FIXED_DRIVE``: thrusters for a thrust calibration), else a weight when a hung mass
    is given, else None (a pendulum)."""
    if parameters.get("drive") in RUN_DRIVES:
        return parameters["drive"]
    if kind in FIXED_DRIVE:
        return FIXED_DRIVE[kind]
    return "weight" if parameters.get("hung_mass_kg") is not None else None


def _like_escaped(text: str) -> str:
    return text.replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_")


@dataclass(frozen=True)
class RunFilter:
    """Which runs to list; every field None means no condition. ``since`` ≤ start <
    ``until`` (a naive datetime is UTC); ``search`` matches, case-insensitively, any part
    of the metadata (operator, notes, tags, free keys and values), the vehicle, the
    imported file's name or the start of the run id."""

    kind: str | None = None
    status: str | None = None
    vehicle: str | None = None
    drive: str | None = None
    source: str | None = None
    tag: str | None = None
    search: str | None = None
    since: datetime | None = None
    until: datetime | None = None

    @property
    def reads_vehicle(self) -> bool:
        """Whether the filter reads the vehicle's name (``vehicle``, ``search``)."""
        return self.vehicle is not None or self.search is not None

    def where(self, query: sa.Select) -> sa.Select:
        """``query`` (which joins ``vehicles`` when :attr:`reads_vehicle`) narrowed to the
        matching runs."""
        c = runs_t.c
        if self.kind is not None:
            query = query.where(c.kind == checks.check_kind("kind", self.kind))
        if self.status is not None:
            query = query.where(
                c.status == checks.check_choice("status", self.status, RUN_STATUSES)
            )
        if self.vehicle is not None:
            query = query.where(vehicles.c.name == self.vehicle)
        if self.drive is not None:
            allowed = (*RUN_DRIVES, "none")
            drive = checks.check_choice("drive", self.drive, allowed)
            query = query.where(c.drive.is_(None) if drive == "none" else c.drive == drive)
        if self.source is not None:
            query = query.where(c.source == checks.check_choice("source", self.source, RUN_SOURCES))
        if self.tag is not None:
            tagged = sa.select(run_tags.c.run_id).where(
                run_tags.c.tag == check_tag("tag", self.tag)
            )
            query = query.where(c.id.in_(tagged))
        if self.search is not None:
            query = query.where(self._search_clause(self.search))
        if self.since is not None:
            query = query.where(c.started_at >= checks.unix_seconds("since", self.since))
        if self.until is not None:
            query = query.where(c.started_at < checks.unix_seconds("until", self.until))
        return query

    @staticmethod
    def _search_clause(search: str) -> sa.ColumnElement[bool]:
        text = search.strip() if isinstance(search, str) else ""
        if not text or len(text) > MAX_SEARCH_CHARS:
            raise ValueError(
                f"search: {search!r} is not allowed; use a text of 1-{MAX_SEARCH_CHARS} characters"
            )
        pattern = f"%{_like_escaped(text)}%"
        c = runs_t.c
        return sa.or_(
            sa.cast(c.metadata, sa.Text).ilike(pattern, escape="\\"),
            vehicles.c.name.ilike(pattern, escape="\\"),
            c.source_file.ilike(pattern, escape="\\"),
            c.uuid.like(f"{_like_escaped(text.lower())}%", escape="\\"),
        )
