"""``GET /api/kinds``: every run kind of the registry (``daq.procedures.kinds``) with the
JSON Schema of its start request and of its import fields, so a client (the browser's start
forms among them) renders what each kind takes without a copy of it."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends
from pydantic import BaseModel, Field

from api.http.deps import require_read
from api.http.schemas import error_responses
from daq.procedures.kinds import describe_kinds

router = APIRouter(prefix="/api", tags=["rig"])


class KindImportOut(BaseModel):
    position: str = Field(description="What the file's position column holds, with its unit.")
    schema_: dict[str, Any] | None = Field(
        alias="schema", description="JSON Schema of the kind's own import fields (null: none)."
    )


class KindOut(BaseModel):
    kind: str = Field(description="The run kind as runs store it: tow, spin, …")
    label: str = Field(description="What an operator reads: 'tow test'.")
    help: str = Field(description="One sentence on the test.")
    command: str | None = Field(description="`rig <command>` (null: the rig does not run it).")
    route: str | None = Field(description="`POST /api/jobs/<route>` (null: not run on the rig).")
    schema_: dict[str, Any] | None = Field(
        alias="schema", description="JSON Schema of the start request (the route's body)."
    )
    estimator: str | None = Field(description="The fit its runs take (null: none).")
    methods: list[str] = Field(description="Estimation methods, the first the default.")
    method_labels: dict[str, str] = Field(
        description="How the browser's method menu words each method (one missing: its name)."
    )
    import_: KindImportOut | None = Field(
        alias="import", description="How a CSV is imported as this kind (null: it is not)."
    )


@router.get(
    "/kinds",
    response_model=list[KindOut],
    response_model_by_alias=True,
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def get_kinds() -> list[dict[str, Any]]:
    """Every run kind: labels, its start request's JSON Schema (field names, types,
    descriptions, defaults; the rig file's limits are checked when a job is submitted),
    its command and route, its estimation methods and its import fields."""
    return describe_kinds()
