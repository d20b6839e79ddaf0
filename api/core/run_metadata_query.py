"""A run's metadata as a person gives it when recording or importing (:class:`RunMetadataQuery`):
the options of every command that records or imports runs (``rig tow``, …, ``rig import``;
``rig annotate`` too) and the query parameters of ``POST /api/runs/import``. Its known keys
(range, help, option) are made from their one declaration, ``daq.store.run_metadata.KNOWN``,
as the JSON object's are (``daq.procedures.procedure_request.RunMetadataIn``); here only the
tags (``--tag``, repeated) and the free keys (``--meta KEY=VALUE``) are added.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from daq.procedures.procedure_request import known_keys_model
from daq.store.run_metadata import (
    MAX_EXTRA_KEYS,
    MAX_TAGS,
    check_run_metadata,
    check_tag,
    parse_meta_pair,
)

#: The fields that are no metadata key of their own: the tags and the free ``KEY=VALUE``
#: pairs (``create_model``'s ``(annotation, default)``).
_LIST_FIELDS: dict[str, Any] = {
    "tag": (
        Annotated[
            list[str],
            Field(max_length=MAX_TAGS,
                  description="A tag to find the run by, e.g. fins-v2 (an import's replace "
                  "the file's tags; rig annotate adds them)."),
            Flag("--tag", metavar="TAG"),
        ],
        [],
    ),
    "meta": (
        Annotated[
            list[str],
            Field(max_length=MAX_EXTRA_KEYS,
                  description="Any other key as KEY=VALUE, e.g. ballast=B3 (numbers stay "
                  "numbers)."),
            Flag("--meta", metavar="KEY=VALUE"),
        ],
        [],
    ),
}  # fmt: skip


class _RunMetadataOptions(BaseModel):
    """Who ran the test, the water, notes, tags and free keys; every other field is stored
    under its own name (a known key of ``daq.store.run_metadata.KNOWN``)."""

    model_config = ConfigDict(frozen=True)
    if TYPE_CHECKING:  # the fields made below that this class reads
        tag: list[str]
        meta: list[str]

    def metadata(self) -> dict[str, Any]:
        """The run's metadata as stored (texts stripped, tags without repeats; unset keys
        left out); ``ValueError`` naming the field, the value and what is allowed."""
        given = self.model_dump(exclude_none=True, exclude=set(_LIST_FIELDS))
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


def run_metadata_query_model() -> type[_RunMetadataOptions]:
    """The model of the metadata options, made from the known keys as declared now."""
    return known_keys_model(
        "RunMetadataQuery", _RunMetadataOptions, checked_by_model=True, **_LIST_FIELDS
    )


if TYPE_CHECKING:  # the type checker sees the base; the fields are made from the table
    RunMetadataQuery = _RunMetadataOptions
else:
    RunMetadataQuery = run_metadata_query_model()
