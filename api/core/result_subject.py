"""What a stored result is of, in a few words — ``surge tow / output-error``, ``roll free
decay``, ``pendulum swing (surge) / output-error``, ``thrust calibration`` — read from its
kind and document in this one place, so the results list on the page (``GET /api/results``'
``subject``) and ``rig results`` name a result alike and never by guessing at its shape."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from daq.vocabulary import AXES


def subject(kind: str, data: Mapping[str, Any]) -> str:
    """The result's subject: the record it was made of (test and degree of freedom) and the
    method; ``—`` when the document names neither."""
    method = data.get("method")
    if kind == "calibration":
        return "thrust calibration"
    if kind == "crosscheck":
        return f"{data.get('axis', '')} cross-check".strip()
    if data.get("analysis") == "pendulum":
        record = f"pendulum swing ({data.get('axis')})"
    elif data.get("kind") == "decay":
        record = f"{data.get('dof')} free decay"
    elif kinds := [k for k, terms in AXES.items() if terms.axis == data.get("axis")]:
        # a tow or a spin, on the line its dof names (a settling sphere: a heave tow)
        record = f"{data.get('dof') or data['axis']} {kinds[0]}"
    else:
        record = str(data.get("analysis") or "")
    return " / ".join(part for part in (record, method) if part) or "—"
