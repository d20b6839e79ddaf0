"""Analysis routes: AHP weights from judgement matrices, and the sensitivity / model
reduction / identifiability analysis of a vehicle (seed 004) on the 6-DOF model.

A full analysis takes ≈ 0.3 s on the fixture vehicles (bench/sensitivity_speed.py), so it
runs in the request (a worker thread), not as a job.
"""

from __future__ import annotations

from functools import partial
from typing import Annotated

from fastapi import APIRouter, Depends, HTTPException
from pydantic import BaseModel, ConfigDict, Field

from api.core import analysis as analysis_common
from api.core import sixdof as sixdof_common
from api.http.deps import RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import error_responses
from daq.store import ResultNotFound
from estimation.vehicle.ahp import Judgement
from estimation.vehicle.description import COEFFICIENT_NAMES, DOFS
from estimation.vehicle.responses import RESPONSE_NAMES, RESPONSES

router = APIRouter(prefix="/api/analysis", tags=["analysis"])
#: Right-hand-side evaluations one simulation may cost (a typical one needs a few hundred).
MAX_EVALUATIONS = 200_000
#: A request's analysis stops (422) past this many seconds (a typical one takes 0.3 s).
TIME_LIMIT_S = 30.0
#: At most this many extra thresholds per request (each costs one reduced-model run per
#: criterion).
MAX_THRESHOLDS = 20
_Judgement = Annotated[float, Field(gt=0, le=1e3)]


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class MatrixIn(Strict):
    """One pairwise judgement matrix (Saaty 1–9 scale, a_ji = 1/a_ij)."""

    name: str | None = Field(None, max_length=100, description="Names the matrix in errors.")
    matrix: list[Annotated[list[_Judgement], Field(min_length=1, max_length=15)]] = Field(
        min_length=1, max_length=15, description="n×n, positive, reciprocal."
    )
    labels: list[Annotated[str, Field(max_length=100)]] | None = Field(
        None, max_length=15, description="The n items compared (e.g. response names)."
    )


class AHPRequest(Strict):
    """One matrix, or a two-level hierarchy: ``criteria`` compares the groups, each group
    compares its leaves."""

    matrix: list[Annotated[list[_Judgement], Field(min_length=1, max_length=15)]] | None = Field(
        None, min_length=1, max_length=15
    )
    labels: list[Annotated[str, Field(max_length=100)]] | None = Field(None, max_length=15)
    name: str | None = Field(None, max_length=100)
    criteria: MatrixIn | None = None
    groups: list[MatrixIn] | None = Field(None, min_length=1, max_length=15)


class SensitivityRequest(Strict):
    """The analysis of one vehicle; every field but ``vehicle`` has a default."""

    vehicle: str = Field(description="Vehicle name (GET /api/vehicles), e.g. 'benbam'.")
    estimates: list[Annotated[int, Field(ge=1, le=2**62)]] = Field(
        default_factory=list,
        max_length=len(DOFS),
        description="Stored estimation result ids to plug in (one per axis).",
    )
    responses: list[str] | None = Field(
        None,
        max_length=len(RESPONSE_NAMES),
        description="Response names; default every one the vehicle can do: "
        + ", ".join(RESPONSE_NAMES),
    )
    weights: dict[str, Annotated[float, Field(ge=0, le=1e6)]] | None = Field(
        None, description="Response weights (renormalised); default equal. Or give ahp."
    )
    ahp: AHPRequest | None = Field(None, description="Judgement matrices over the responses.")
    thresholds: list[Annotated[float, Field(gt=0, le=1e3)]] = Field(
        default_factory=list,
        max_length=MAX_THRESHOLDS,
        description="Extra composite thresholds (added to 0.005, 0.0075, 0.01).",
    )
    keep: list[str] = Field(
        default_factory=list,
        max_length=len(COEFFICIENT_NAMES),
        description="Coefficients never removed, e.g. 'added_mass.surge'.",
    )
    delta: float = Field(0.01, gt=0, lt=0.5, description="Relative step of S (±δ·H).")
    forces: dict[str, Annotated[float, Field(ge=-1e5, le=1e5)]] | None = Field(
        None,
        description="Step size per axis (N or N·m), e.g. {'surge': 20}; default half the "
        "thrusters' reach.",
    )
    distance_time_s: float | None = Field(
        None, gt=0, le=1e5, description="t of distance_at_t, s; default 3 surge time constants."
    )


@router.get("/responses", dependencies=[Depends(require_read)], responses=error_responses(401))
def list_responses() -> list[dict]:
    """The response library: name, unit, the manoeuvre it is measured on, how."""
    return [r.to_json() for r in RESPONSES]


@router.post("/ahp", dependencies=[Depends(require_write)], responses=error_responses(401, 422))
def ahp_weights(body: AHPRequest) -> dict:
    """Weights (principal eigenvector), λ_max, CI, RI, CR of one matrix or a two-level
    hierarchy (global weights, overall CR = Σa·CI/Σa·RI). CR ≥ 0.1 → 422 naming the matrix."""
    spec = body.model_dump(exclude_none=True)
    if "groups" not in spec and "matrix" not in spec:
        raise ValueError("matrix: give a judgement matrix, or criteria and groups")
    if "groups" in spec and "criteria" not in spec:
        raise ValueError("criteria: give the matrix comparing the groups")
    result = analysis_common.judgement(spec)
    out = result.to_json()
    if "groups" not in spec and isinstance(result, Judgement):  # one matrix: a Judgement
        out["weights_by_label"] = dict(zip(result.labels, result.weights, strict=True))
    return out


@router.post(
    "/sensitivity",
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 422),
)
def sensitivity(body: SensitivityRequest, store: StoreDep, runner: RunnerDep) -> dict:
    """S, Sc, composite ranking, joint threshold sweep, ±σ changes, identifiability ranking
    and the next test for a vehicle (docs/sensitivity.md). Computed in the analysis worker
    process, not the rig's."""
    study = partial(
        analysis_common.analyse_vehicle,
        vehicle_name=body.vehicle,
        estimates=body.estimates,
        responses=body.responses,
        weights=body.weights,
        ahp=body.ahp.model_dump(exclude_none=True) if body.ahp else None,
        thresholds=body.thresholds,
        keep=body.keep,
        delta=body.delta,
        forces=body.forces,
        distance_time_s=body.distance_time_s,
        max_evaluations=MAX_EVALUATIONS,
        time_limit_s=TIME_LIMIT_S,
    )
    try:
        return runner.analysis.executor_for(store).call(store.url, study)
    except (sixdof_common.VehicleNotFound, ResultNotFound) as err:
        raise HTTPException(404, str(err)) from None
