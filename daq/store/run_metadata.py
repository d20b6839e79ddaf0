"""Free metadata on a run: who ran it, the water temperature, notes, tags and any other
key/value a lab wants to keep — checked here once for the store, the API and the CLI.

A run's ``metadata`` is one flat JSON object::

    {"operator": "Ada", "water_temperature_c": 18.5, "salinity_g_kg": 35.165,
     "notes": "new fins", "tags": ["fins-v2", "baseline"], "ballast": "B3", "depth_m": 1.2}

The known keys have their own rules (the theory comparison computes the water's ρ from
the temperature and salinity); any other key is a lower-case name and its value a string,
number or boolean. Messages name the field
(``metadata.tags``) with the given value and what is allowed.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

#: Water temperature range a lab tank can have, °C (sea water freezes at -1.9 °C).
WATER_TEMPERATURE_RANGE_C = (-2.0, 50.0)
#: Absolute salinity a lab tank's water can have, g/kg: fresh water to the saltiest sea
#: water (the Red Sea's ≈ 41); the water model (``estimation.water``) covers the same.
SALINITY_RANGE_G_KG = (0.0, 42.0)
MAX_TAGS = 20
MAX_TAG_CHARS = 40
MAX_NOTES_CHARS = 10_000
MAX_TEXT_CHARS = 200
MAX_EXTRA_KEYS = 30
#: Where a run came from, added by the job runner and sequences (who started it, the job,
#: the sequence and its step): not counted against the free keys a person may add.
ORIGIN_KEYS = ("started_by", "job_id", "sequence", "sequence_step")
_KEY = re.compile(r"^[a-z][a-z0-9_]{0,39}$")
_TAG = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.:+-]*$")


def _text(field: str, value: object, limit: int) -> str:
    if not isinstance(value, str) or not value.strip() or len(value) > limit:
        raise ValueError(
            f"{field}: {value!r} is not allowed; use a non-empty text of at most {limit} characters"
        )
    return value.strip()


def check_tag(field: str, value: object) -> str:
    """A tag: 1-40 letters, digits or ``_ . : + -``, starting with a letter or digit."""
    if not isinstance(value, str) or len(value) > MAX_TAG_CHARS or not _TAG.match(value):
        raise ValueError(
            f"{field}: {value!r} is not allowed; use 1-{MAX_TAG_CHARS} letters, digits or "
            "'_.:+-' starting with a letter or digit (e.g. 'fins-v2')"
        )
    return value


@dataclass(frozen=True)
class MetadataKey:
    """A known key with its own rule, declared once: a text of at most ``max_chars``
    characters, or a finite number within ``number_range`` (in ``unit``). The store's check
    (:func:`check_run_metadata`), the JSON object of procedure requests and of ``PATCH
    .../metadata`` (``daq.procedures.procedure_request.RunMetadataIn``), the query and the
    commands' options (``api.core.run_metadata_query.RunMetadataQuery``: ``option``,
    ``metavar``) and the docs' tables all follow from it."""

    name: str
    #: What it is, without its unit: "Water temperature".
    what: str
    #: The command's option (``--water-temp``) and its placeholder in ``--help``.
    option: str
    metavar: str
    max_chars: int = MAX_TEXT_CHARS
    number_range: tuple[float, float] | None = None
    unit: str = ""
    #: What values in the range mean, said after the unit: "0 = fresh water, …".
    meaning: str = ""
    #: A form's label, short ("Salinity"; default: ``what``); its unit is added.
    label: str = ""

    @property
    def title(self) -> str:
        """A form's label with the unit: "Salinity (g/kg)"."""
        label = self.label or self.what
        return f"{label} ({self.unit})" if self.unit else label

    @property
    def description(self) -> str:
        """The help: "Absolute salinity of the tank's water, g/kg (0 = fresh water, …)."."""
        unit = f", {self.unit}" if self.unit else ""
        meaning = f" ({self.meaning})" if self.meaning else ""
        return f"{self.what}{unit}{meaning}."

    def check(self, field: str, value: object) -> Any:
        """``value`` checked (a text stripped, a number as float); ``ValueError`` naming
        ``field``, the value and what is allowed."""
        if self.number_range is None:
            return _text(field, value, self.max_chars)
        low, high = self.number_range
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not (math.isfinite(value) and low <= value <= high)
        ):
            meaning = f" ({self.meaning})" if self.meaning else ""
            raise ValueError(
                f"{field}: {value!r} is not allowed; use {low:g} ≤ {self.name} ≤ {high:g} "
                f"{self.unit}{meaning}"
            )
        return float(value)


#: The known keys besides ``tags`` (a list: ``tags`` in JSON, ``--tag`` repeated), in the
#: order the models, the options and the docs list them: adding a key here is the one edit
#: (``tests/api/test_metadata_keys.py`` adds one and follows it everywhere).
KNOWN: tuple[MetadataKey, ...] = (
    MetadataKey("operator", "Who runs the test", "--operator", "NAME", label="Operator"),
    MetadataKey("water_temperature_c", "Water temperature", "--water-temp", "°C",
                number_range=WATER_TEMPERATURE_RANGE_C, unit="°C"),
    MetadataKey("salinity_g_kg", "Absolute salinity of the tank's water", "--salinity",
                "G_PER_KG", number_range=SALINITY_RANGE_G_KG, unit="g/kg",
                meaning="0 = fresh water, 35.165 = standard sea water", label="Salinity"),
    MetadataKey("notes", "Free notes on the run", "--notes", "TEXT", max_chars=MAX_NOTES_CHARS,
                label="Notes"),
)  # fmt: skip


def is_free_key(key: str) -> bool:
    """A key a person added (counted against :data:`MAX_EXTRA_KEYS`): no known key, no
    origin key."""
    return key != "tags" and key not in ORIGIN_KEYS and all(k.name != key for k in KNOWN)


def _value(field: str, key: str, value: object) -> Any:
    known = next((k for k in KNOWN if k.name == key), None)
    if known is not None:
        return known.check(field, value)
    if key == "tags":
        if not isinstance(value, list | tuple) or len(value) > MAX_TAGS:
            raise ValueError(
                f"{field}: {value!r} is not allowed; use a list of at most {MAX_TAGS} tags"
            )
        tags = [check_tag(f"{field}[{i}]", tag) for i, tag in enumerate(value)]
        return list(dict.fromkeys(tags))  # in the order given, without repeats
    if isinstance(value, str):
        return _text(field, value, MAX_TEXT_CHARS)
    if isinstance(value, bool) or (isinstance(value, int | float) and math.isfinite(value)):
        return value
    raise ValueError(
        f"{field}: {value!r} is not allowed; use a text, a finite number or true/false"
    )


def check_run_metadata(
    value: object, *, prefix: str = "metadata.", allow_null: bool = False
) -> dict[str, Any]:
    """The checked metadata (texts stripped, tags without repeats); ``allow_null`` lets a
    value be None (an update that removes the key)."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ValueError(f"{prefix.rstrip('.') or 'metadata'}: expected an object, got {value!r}")
    out: dict[str, Any] = {}
    extra = 0
    for key, item in value.items():
        if not isinstance(key, str) or not _KEY.match(key):
            raise ValueError(
                f"{prefix}{key}: this key is not allowed; use a lower-case name of 1-40 "
                "letters, digits or '_' starting with a letter (e.g. 'ballast')"
            )
        extra += is_free_key(key)
        if extra > MAX_EXTRA_KEYS:
            raise ValueError(f"{prefix}{key}: more than {MAX_EXTRA_KEYS} free keys on a run")
        if item is None and allow_null:
            out[key] = None
            continue
        out[key] = _value(f"{prefix}{key}", key, item)
    return out


def merge_run_metadata(current: dict[str, Any], changes: dict[str, Any]) -> dict[str, Any]:
    """``current`` updated by checked ``changes`` (a None value removes the key)."""
    merged = dict(current)
    for key, value in changes.items():
        if value is None:
            merged.pop(key, None)
        else:
            merged[key] = value
    extra = [k for k in merged if is_free_key(k)]
    if len(extra) > MAX_EXTRA_KEYS:
        raise ValueError(f"metadata: {len(extra)} free keys; at most {MAX_EXTRA_KEYS} on a run")
    return merged


def parse_meta_pair(text: str) -> tuple[str, Any]:
    """``KEY=VALUE`` from the command line: a number when VALUE reads as one, else text."""
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise ValueError(f"{text!r} is not allowed; use KEY=VALUE (e.g. ballast=B3)")
    raw = raw.strip()
    value: Any = raw
    if re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?", raw):
        number = float(raw)
        value = int(number) if re.fullmatch(r"[-+]?\d+", raw) else number
    return key.strip(), value
