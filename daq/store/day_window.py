"""Dates as a user means them: ``since``/``until`` given as a calendar day (or a moment)
in the user's time zone, both days included, turned into the store's start-time window
``since ≤ started_at < until``."""

from __future__ import annotations

import re
from datetime import UTC, date, datetime, time, timedelta, tzinfo
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

_OFFSET = re.compile(r"^(?:UTC|GMT)?\s*([+-])(\d{1,2})(?::?(\d{2}))?$")
_DAY = re.compile(r"^\d{4}-\d{2}-\d{2}$")


def parse_tz(field: str, text: str | None) -> tzinfo | None:
    """An IANA zone (``Europe/Oslo``), ``UTC`` or an offset (``+01:00``, ``-0530``);
    None when not given."""
    if text is None or not text.strip():
        return None
    text = text.strip()
    if text.upper() in ("UTC", "Z", "GMT"):
        return UTC
    match = _OFFSET.match(text)
    if match:
        sign, hours, minutes = match.groups()
        delta = timedelta(hours=int(hours), minutes=int(minutes or 0))
        if delta <= timedelta(hours=14):
            from datetime import timezone

            return timezone(-delta if sign == "-" else delta)
    else:
        try:
            return ZoneInfo(text)
        except (ZoneInfoNotFoundError, ValueError):
            pass
    raise ValueError(
        f"{field}: {text!r} is not allowed; use an IANA time zone such as 'Europe/Oslo', "
        "'UTC' or an offset such as '+01:00'"
    )


def parse_moment(field: str, text: str, *, today: date | None = None) -> date | datetime:
    """``YYYY-MM-DD`` (a day), ``today``/``yesterday``, or an ISO 8601 date-time."""
    value = text.strip()
    words = {"today": 0, "yesterday": 1}
    if value.lower() in words:
        return (today or date.today()) - timedelta(days=words[value.lower()])
    try:
        if _DAY.match(value):
            return date.fromisoformat(value)
        return datetime.fromisoformat(value.replace("Z", "+00:00").replace(" ", "T", 1))
    except ValueError:
        raise ValueError(
            f"{field}: {text!r} is not allowed; use a day YYYY-MM-DD, 'today', 'yesterday' "
            "or a date-time YYYY-MM-DDTHH:MM[:SS][±HH:MM]"
        ) from None


def start_window(
    since: date | datetime | None, until: date | datetime | None, tz: tzinfo | None
) -> tuple[datetime | None, datetime | None]:
    """The aware (since, until-exclusive) datetimes of a user's window: a day ``since``
    starts at its local midnight; a day ``until`` ends at the next local midnight (the
    whole day included); a date-time ``until`` is included too. A naive date-time is
    local to ``tz`` (UTC when None)."""
    zone = tz or UTC

    def aware(moment: date | datetime, *, end: bool) -> datetime:
        if isinstance(moment, datetime):
            moment = moment if moment.tzinfo else moment.replace(tzinfo=zone)
            return moment + timedelta(microseconds=1) if end else moment
        day = moment + timedelta(days=1) if end else moment
        return datetime.combine(day, time(), tzinfo=zone)

    low = None if since is None else aware(since, end=False)
    high = None if until is None else aware(until, end=True)
    return low, high
