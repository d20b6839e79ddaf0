"""A run's metadata as a person gives it when recording or importing (:class:`RunMetadataQuery`):
each key declared once (range, help, option) for the options of every command that records
or imports runs (``rig tow``, …, ``rig import``; ``rig annotate`` too) and the query
parameters of ``POST /api/runs/import``. The rules of the stored metadata (tags, free keys)
are ``daq.store.run_metadata``'s; a JSON body gives the same keys as an object
(``daq.procedures.procedure_request.RunMetadataIn``).
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from daq.store.run_metadata import (
    MAX_EXTRA_KEYS,
    MAX_NOTES_CHARS,
    MAX_TAGS,
    MAX_TEXT_CHARS,
    SALINITY_RANGE_G_KG,
    WATER_TEMPERATURE_RANGE_C,
    check_run_metadata,
    check_tag,
    parse_meta_pair,
)

#: Fields that are no metadata key of their own: the tags and the free ``KEY=VALUE`` pairs.
_LISTS = ("tag", "meta")


class RunMetadataQuery(BaseModel):
    """Who ran the test, the water temperature, notes, tags and free keys; every other field
    is stored under its own name (a free key with the store's rules)."""

    model_config = ConfigDict(frozen=True)

    operator: Annotated[
        str | None,
        Field(min_length=1, max_length=MAX_TEXT_CHARS, description="Who runs the test."),
        Flag("--operator", metavar="NAME"),
    ] = None
    water_temperature_c: Annotated[
        float | None,
        Field(ge=WATER_TEMPERATURE_RANGE_C[0], le=WATER_TEMPERATURE_RANGE_C[1],
              allow_inf_nan=False, description="Water temperature, °C."),
        Flag("--water-temp", metavar="°C"),
    ] = None  # fmt: skip
    salinity_g_kg: Annotated[
        float | None,
        Field(ge=SALINITY_RANGE_G_KG[0], le=SALINITY_RANGE_G_KG[1], allow_inf_nan=False,
              description="Absolute salinity of the tank's water, g/kg (0 = fresh water, "
              "35.165 = standard sea water)."),
        Flag("--salinity", metavar="G_PER_KG"),
    ] = None  # fmt: skip
    notes: Annotated[
        str | None,
        Field(min_length=1, max_length=MAX_NOTES_CHARS, description="Free notes on the run."),
        Flag("--notes", metavar="TEXT"),
    ] = None
    tag: Annotated[
        list[str],
        Field(max_length=MAX_TAGS,
              description="A tag to find the run by, e.g. fins-v2 (an import's replace the "
              "file's tags; rig annotate adds them)."),
        Flag("--tag", metavar="TAG"),
    ] = []  # fmt: skip
    meta: Annotated[
        list[str],
        Field(max_length=MAX_EXTRA_KEYS,
              description="Any other key as KEY=VALUE, e.g. ballast=B3 (numbers stay numbers)."),
        Flag("--meta", metavar="KEY=VALUE"),
    ] = []  # fmt: skip

    def metadata(self) -> dict[str, Any]:
        """The run's metadata as stored (texts stripped, tags without repeats; unset keys
        left out); ``ValueError`` naming the field, the value and what is allowed."""
        given = self.model_dump(exclude_none=True, exclude=set(_LISTS))
        if self.tag:
            given["tags"] = [check_tag("tag", t) for t in self.tag]
        checked = check_run_metadata(given, prefix="")
        free: dict[str, Any] = {}
        for pair in self.meta:
            try:
                key, value = parse_meta_pair(pair)
            except ValueError as err:
                raise ValueError(f"meta: {err}") from None
            free[key] = value
        return checked | check_run_metadata(free, prefix="meta ")
