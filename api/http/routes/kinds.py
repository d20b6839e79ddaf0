"""``GET /api/kinds``: every run kind of the registry (``daq.procedures.run_kinds``) with the
JSON Schema of its start request and of its import fields, its axis, drives, what the
live plot shows of it and the units of its estimates, so a client (the browser's start
forms, method menu, live plot, estimation and cross-check pages among them) renders what
each kind takes without a copy of it."""

from __future__ import annotations

from typing import Any

from fastapi import Depends
from pydantic import BaseModel, Field

from api.http.app_codes import app_router
from api.http.deps import require_read
from api.http.schemas import error_responses
from daq.procedures.kind_spec import KindSpec
from daq.procedures.run_kinds import KINDS

router = app_router("/api", "rig")


class KindImportOut(BaseModel):
    position: str = Field(description="What the file's position column holds, with its unit.")
    schema_: dict[str, Any] | None = Field(
        alias="schema", description="JSON Schema of the kind's own import fields (null: none)."
    )


class KindRateOut(BaseModel):
    key: str = Field(description="The derived channel: speed, yaw_rate.")
    label: str = Field(description="How the live plot names it: 'speed (from position)'.")
    unit: str = Field(description="Its unit: m/s, rad/s.")
    of: str = Field(description="The position channel it is the rate of: tow_position.")


class KindShownOut(BaseModel):
    field: str = Field(description="The run parameter: force_n, start_angle_rad.")
    unit: str = Field(description="Its unit: N, rad.")


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
    axis: str | None = Field(description="The axis it moves: surge, yaw, … (null: none).")
    drives: list[str] = Field(description="What may drive it: weight, thrusters (none: []).")
    live: list[str] = Field(
        description="What the live plot shows of its runs by default (`thrusters`: every "
        "thruster's command)."
    )
    rate: KindRateOut | None = Field(
        description="The rate the live plot derives from its position (null: none)."
    )
    planned: bool = Field(
        description="The test planner chooses its runs (a campaign's axes are these kinds')."
    )
    shown: KindShownOut | None = Field(
        description="The parameter a run list shows of its runs (null: none)."
    )
    units: dict[str, dict[str, str]] = Field(
        description="Per axis (or dof) its estimator's results may be on, the unit of each "
        "quantity they report: {surge: {inertia: kg, linear_damping: N·s/m, …, position: m, "
        "velocity: m/s}} ({}: none, or its results carry their own)."
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
    its command and route, its estimation methods, its import fields, its axis and drives,
    and what the live plot shows of its runs."""
    return [_described(spec) for spec in KINDS.values()]


def _described(spec: KindSpec) -> dict[str, Any]:
    est, terms, shown = spec.estimator, spec.axis, spec.shown_parameter
    rate = None
    if terms is not None and terms.rate is not None:
        unit = f"{terms.unit}/s"
        rate = {
            "key": terms.rate,
            "label": terms.rate_label,
            "unit": unit,
            "of": terms.position_channel,
        }
    return {
        "kind": str(spec.kind),
        "label": spec.label,
        "help": spec.help,
        "command": spec.command,
        "route": spec.route,
        "schema": None if spec.request is None else spec.request.model_json_schema(),
        "estimator": None if est is None else est.name,
        "methods": [] if est is None else list(est.methods),
        "method_labels": {} if est is None else est.method_labels,
        "import": None if spec.imports is None else spec.imports.to_json(),
        "axis": None if terms is None else str(terms.axis),
        "drives": list(spec.drives),
        "live": list(spec.live_channels),
        "rate": rate,
        "planned": spec.envelope is not None,
        "shown": None if shown is None else {"field": shown[0], "unit": shown[1]},
        "units": {} if est is None else est.units_of(),
    }
