"""What a towrig CSV export says about its run, read back from its ``#`` header.

An export opens with ``# towrig run export: …`` and one ``# key: value`` line per run
attribute (``daq.store.run_attributes``): the kind, vehicle, rig name, drive, the
parameters as JSON (the signed load, the hung mass, a logged drive's channel), the release
instant ``release_t_s`` (s on the file's ``t`` axis). An import of such a file takes them
back, so a run exported here and imported again is the same run without restating it.

A CSV another tool wrote may name its vehicle too: :func:`vehicle_in_header` reads a
leading ``# vehicle: NAME`` (or ``# Vehicle = NAME``) comment line, or the ``vehicle`` of
a ``# metadata: {…}`` comment.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: The first line's text that marks a towrig export.
EXPORT_MARK = "towrig run export"
#: A leading comment line naming the vehicle: ``# vehicle: BENBAM``, ``# Vehicle = X``.
_VEHICLE_LINE = re.compile(r"#\s*vehicle\s*[:=]\s*(?P<name>\S.*?)\s*$", re.IGNORECASE)
#: Attributes holding a number (written with ``repr``).
_NUMBERS = ("release_t_s", "duration_s", "sample_count")


@dataclass(frozen=True)
class ExportHeader:
    """The run attributes of an export's header (empty for any other CSV)."""

    attributes: dict[str, Any] = field(default_factory=dict)

    @property
    def is_export(self) -> bool:
        return bool(self.attributes)

    @property
    def kind(self) -> str | None:
        value = self.attributes.get("kind")
        return value if isinstance(value, str) else None

    @property
    def parameters(self) -> dict[str, Any]:
        value = self.attributes.get("parameters")
        return value if isinstance(value, dict) else {}

    def text(self, key: str) -> str | None:
        """A string attribute (``vehicle``, ``rig_name``, ``drive``, ``run_id``), or None."""
        value = self.attributes.get(key)
        return value if isinstance(value, str) and value else None

    @property
    def release_t_s(self) -> float | None:
        """The release, s on the file's ``t`` axis (the recorded event or the given time)."""
        value = self.attributes.get("release_t_s")
        return float(value) if isinstance(value, int | float) else None

    def source(self) -> str:
        """How messages name it: ``the file's header (tow run 39f388d3 as exported)``."""
        run = (self.text("run_id") or "")[:8]
        return f"the file's header ({self.kind} run {run} as exported)"


def _value(key: str, text: str) -> Any:
    if text[:1] in '{["':
        try:
            return json.loads(text)
        except json.JSONDecodeError:
            return text
    if key in _NUMBERS:
        try:
            return float(text)
        except ValueError:
            return text
    return text


def read_export_header(path: str | Path) -> ExportHeader:
    """The run attributes of a towrig export's leading comment lines; an empty header for a
    CSV that is not one (its first line does not say ``# towrig run export``)."""
    attributes: dict[str, Any] = {}
    with open(path, encoding="utf-8", errors="replace") as f:
        first = f.readline()
        if not (first.startswith("#") and EXPORT_MARK in first):
            return ExportHeader()
        for line in f:
            if not line.startswith("#"):
                break
            key, sep, text = line.lstrip("#").strip().partition(": ")
            if sep:
                attributes[key] = _value(key, text.strip())
    return ExportHeader(attributes)


def vehicle_in_header(path: str | Path) -> str | None:
    """The vehicle a CSV's leading comment lines name (``# vehicle: NAME``, or the
    ``vehicle`` of a ``# metadata: {…}`` line), whoever wrote the file; None when none does."""
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        for line in f:
            if not line.startswith("#"):
                return None
            if found := _VEHICLE_LINE.match(line.strip()):
                return found["name"]
            body = line.lstrip("#").strip()
            if body.startswith("metadata:"):
                value = _value("metadata", body.removeprefix("metadata:").strip())
                named = value.get("vehicle") if isinstance(value, dict) else None
                if isinstance(named, str) and named.strip():
                    return named.strip()
    return None
