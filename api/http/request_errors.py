"""Request errors that are not about a field's value: a path id no resource can have
(→ 404, like an unknown one) and a body that is not JSON at all (→ 422 saying so)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

#: Longest id echoed back in a message (the rest is cut).
_SHOWN_CHARS = 40


def _shown(value: Any) -> str:
    text = str(value)
    return repr(text if len(text) <= _SHOWN_CHARS else text[:_SHOWN_CHARS] + "…")


def request_not_found(errors: Sequence[dict[str, Any]]) -> str | None:
    """``no <thing> with id '…'`` when a path parameter failed validation, else None."""
    for e in errors:
        loc = tuple(e.get("loc", ()))
        if loc[:1] == ("path",) and len(loc) > 1:
            name = str(loc[1])
            thing = name.removesuffix("_id") if name.endswith("_id") else name
            what = (
                f"with id {_shown(e.get('input'))}"
                if name.endswith("_id")
                else _shown(e.get("input"))
            )
            return f"no {thing} {what}"
    return None


def request_json_error(errors: Sequence[dict[str, Any]]) -> dict[str, Any] | None:
    """The error-body entry for a body that is not valid JSON, else None."""
    for e in errors:
        if e.get("type") == "json_invalid":
            reason = (e.get("ctx") or {}).get("error", "cannot be parsed")
            loc = tuple(e.get("loc", ()))
            where = f" at character {loc[1]}" if len(loc) > 1 and isinstance(loc[1], int) else ""
            message = f"request body is not valid JSON: {reason}{where}"
            allowed = "a JSON document"
            return {"field": "body", "value": None, "allowed": allowed, "message": message}
    return None
