"""What a sequence takes: one declaration for the body of ``POST /api/jobs/sequence`` (and
a queued sequence's ``PUT /api/queue/{id}``) and the options of ``rig sequence FILE``
(``request_options``: the fields it can override in the file, ``--rest``). The steps are
checked by ``daq.procedures.sequence.parse_sequence``, as a file's are."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from daq.procedures.flag import Flag
from daq.procedures.params import MAX_REST_S, MAX_SEQUENCE_STEPS, check_rest
from daq.procedures.requests import ProcedureRequest
from daq.vocabulary import RunKind


class SequenceStep(BaseModel):
    model_config = ConfigDict(extra="allow")
    kind: str = Field(description=" | ".join(RunKind))


class SequenceRequest(ProcedureRequest):
    """A sequence, the same content as a sequence TOML file."""

    name: str | None = Field(None, max_length=200)
    rest_s: Annotated[
        float | None,
        Field(
            ge=0,
            le=MAX_REST_S,
            description="Rest between runs to let the water settle, s (default 0; "
            "rig sequence: the file's rest_s).",
        ),
        Flag("--rest"),
    ] = None
    repeats: int | None = None
    steps: list[SequenceStep] = Field(
        max_length=MAX_SEQUENCE_STEPS,
        description=f"[{{kind, ...the step's parameters}}]; at most {MAX_SEQUENCE_STEPS} steps.",
    )

    @field_validator("rest_s", mode="before")
    @classmethod
    def _rest(cls, value: Any) -> Any:
        """Refused in the words of a sequence file's rest (``check_rest``)."""
        if value is not None:
            check_rest(value)
        return value
