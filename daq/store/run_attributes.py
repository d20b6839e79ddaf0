"""A run's description as flat attributes, the same in every export format: NetCDF
global attributes, Parquet schema metadata, CSV header comments.

Values are ``str``, ``int`` or ``float`` (CF attribute types); nested values (parameters,
events, a metadata entry that is a list or dict) are JSON text, booleans ``"true"``/
``"false"``, and missing values are left out.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from daq.store.run_events import RunEvents
from daq.store.run_records import EventInfo, RunInfo

Attribute = str | int | float

#: CF conventions version the NetCDF export follows.
CONVENTIONS = "CF-1.10"
#: Attributes that hold a whole file's text (left out of CSV header comments).
MULTILINE = ("rig_toml", "scenario_toml")


def _attribute(value: Any) -> Attribute | None:
    if value is None:
        return None
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str | int | float):
        return value
    return json.dumps(value, ensure_ascii=False, allow_nan=False, default=str)


def release_time(run: RunInfo, events: Sequence[EventInfo], first_t_mono: float) -> float | None:
    """The brake release, s since the run's first sample: the recorded release event's
    host instant, else the ``release_time_s`` given at import; None when neither is known."""
    released = RunEvents.of(events).release_time
    if released is not None:
        return round(released - first_t_mono, 6)  # µs, like the times
    given = run.parameters.get("release_time_s")
    return float(given) if isinstance(given, int | float) else None


def run_metadata(run: RunInfo) -> dict[str, Any]:
    """The run's free metadata (operator, water temperature, notes, tags…); {} for a run
    or a store version without any."""
    metadata = getattr(run, "metadata", None)
    if metadata is None:
        metadata = run.to_json(include_toml=False).get("metadata")
    return dict(metadata) if isinstance(metadata, dict) else {}


def run_attributes(
    run: RunInfo, events: Sequence[EventInfo], *, release_t: float | None = None
) -> dict[str, Attribute]:
    """Global attributes of the run's export: what, when, on which rig, with which
    parameters, its events and metadata (each metadata key as its own attribute; one
    named like a run attribute is prefixed ``metadata_``)."""
    attrs: dict[str, Any] = {
        "title": f"{run.kind} run {run.id} of {run.vehicle} on {run.rig_name}",
        "Conventions": CONVENTIONS,
        "source": f"towrig {run.software_version}",
        "run_id": run.id,
        "kind": run.kind,
        "status": run.status,
        "reason": run.reason,
        "vehicle": run.vehicle,
        "rig_name": run.rig_name,
        "drive": run.parameters.get("drive"),
        "started_at": run.started_at.isoformat(),
        "stopped_at": run.stopped_at.isoformat() if run.stopped_at else None,
        "duration_s": run.duration_s,
        "sample_count": run.sample_count,
        "parameters": run.parameters,
        "release_t_s": release_t,
        "events": [
            {"time": e.time.isoformat(), "kind": e.kind, "message": e.message, "data": e.data}
            for e in events
        ],
        "rig_toml": run.rig_toml or None,
        "scenario_toml": run.scenario_toml,
    }
    for key, value in run_metadata(run).items():
        attrs[f"metadata_{key}" if key in attrs else str(key)] = value
    out = {key: _attribute(value) for key, value in attrs.items()}
    return {key: value for key, value in out.items() if value is not None}
