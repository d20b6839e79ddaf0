"""Argument checks for the store: every error names the field, the value and what is allowed."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

_KIND = re.compile(r"^[a-z][a-z0-9_]{0,39}$")
_RUN_ID = re.compile(r"^[0-9a-f-]{1,36}$")


def check_kind(field: str, value: object) -> str:
    """A lower-case identifier such as ``tow`` or ``thrust_calibration``."""
    if not isinstance(value, str) or not _KIND.match(value):
        raise ValueError(
            f"{field}: {value!r} is not allowed; use a lower-case name of 1-40 letters, "
            "digits or '_' starting with a letter (e.g. 'tow', 'thrust_calibration')"
        )
    return value


def check_choice(field: str, value: object, allowed: Sequence[str]) -> str:
    """``value`` must be one of ``allowed``."""
    if value not in allowed:
        raise ValueError(f"{field}: {value!r} is not allowed; use one of {', '.join(allowed)}")
    return str(value)


def check_name(field: str, value: object) -> str:
    """A non-empty name of at most 200 characters."""
    if not isinstance(value, str) or not value.strip() or len(value) > 200:
        raise ValueError(f"{field}: {value!r} is not allowed; use a non-empty name (≤ 200 chars)")
    return value.strip()


def check_json(field: str, value: object, *, optional: bool = False) -> dict[str, Any] | None:
    """A dict that serialises to strict JSON (no NaN/Infinity, string keys)."""
    if value is None and optional:
        return None
    if not isinstance(value, dict):
        raise ValueError(f"{field}: expected a dict, got {type(value).__name__} {value!r}")
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{field}: {value!r} is not storable as JSON ({exc})") from exc
    return value


def check_channel_names(value: Sequence[str]) -> tuple[str, ...]:
    """Unique, non-empty channel names without commas."""
    if isinstance(value, str):
        raise ValueError(f"channel_names: expected a list of names, got the string {value!r}")
    names = tuple(value)
    if not names:
        raise ValueError("channel_names: [] is not allowed; a run records at least one channel")
    for name in names:
        if not isinstance(name, str) or not name or "," in name or len(name) > 100:
            raise ValueError(
                f"channel_names: {name!r} is not allowed; use a non-empty name without ','"
            )
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ValueError(f"channel_names: {', '.join(dupes)} repeated; names must be unique")
    return names


def shown_id(value: object, limit: int = 40) -> str:
    """``repr`` of an id for a message, cut after ``limit`` characters."""
    text = str(value)
    return repr(text if len(text) <= limit else text[:limit] + "…")


def check_run_id(value: object) -> str:
    """A run uuid or a prefix of one (hex digits and '-')."""
    text = value.strip().lower() if isinstance(value, str) else value
    if not isinstance(text, str) or not _RUN_ID.match(text):
        raise ValueError(
            "a run id is a uuid or a unique prefix of one (hex digits and '-', ≤ 36 characters)"
        )
    return text


def unix_seconds(field: str, value: datetime | float | None) -> float | None:
    """Unix seconds of an aware datetime (naive means UTC) or a number."""
    if value is None:
        return None
    if isinstance(value, datetime):
        if value.tzinfo is None:
            value = value.replace(tzinfo=UTC)
        return value.timestamp()
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    raise ValueError(f"{field}: {value!r} is not a datetime or finite Unix time")


def check_limit(field: str, value: object, *, minimum: int) -> int:
    """An integer ≥ ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{field}: {value!r} is not allowed; use an integer ≥ {minimum}")
    return value
