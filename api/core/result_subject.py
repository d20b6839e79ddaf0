"""What a stored result is of, in a few words — ``surge tow test / output-error``, ``roll free
decay``, ``surge pendulum free-decay test / output-error``, ``thrust calibration`` — read from its
kind and document in this one place, so the results list on the page (``GET /api/results``'
``subject``) and ``rig results`` name a result alike and never by guessing at its shape."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from daq.vocabulary import AXES

#: What a result of a kind other than an estimation is of.
OTHER_RESULTS: dict[str, Callable[[Mapping[str, Any]], str]] = {
    "calibration": lambda data: "thrust calibration",
    "crosscheck": lambda data: f"{data.get('axis', '')} cross-check".strip(),
}


def subject(kind: str, data: Mapping[str, Any]) -> str:
    """The result's subject: the record it was made of — the line it moved along (its
    ``dof``, else its ``axis``) and the run kind's label from the registry — and the method;
    ``—`` when the document names neither."""
    if kind in OTHER_RESULTS:
        return OTHER_RESULTS[kind](data)
    from daq.procedures.run_kinds import KINDS  # the labels (only a list needs them)

    recorded = data.get("kind") or data.get("analysis")  # schema 1: a pendulum's "analysis"
    if recorded not in KINDS:  # schema 1: a tow's or a spin's named only its axis
        recorded = next((k for k, t in AXES.items() if t.axis == data.get("axis")), None)
    if recorded in KINDS:
        line = data.get("dof") or data.get("axis")  # a settling sphere's tow: heave
        record = " ".join(str(p) for p in (line, KINDS[recorded].label) if p)
    else:
        record = str(data.get("analysis") or "")
    return " / ".join(part for part in (record, data.get("method")) if part) or "—"
