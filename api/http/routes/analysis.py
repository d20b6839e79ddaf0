"""Analysis routes: AHP weights from judgement matrices, and the sensitivity / model
reduction / identifiability analysis of a vehicle (seed 004) on the 6-DOF model.

A full analysis takes ≈ 0.3 s on the fixture vehicles (bench/sensitivity_speed.py), so it
runs in the request (a worker thread), not as a job.
"""

from __future__ import annotations

from functools import partial

from fastapi import Depends, HTTPException

from api.core import analysis as analysis_common
from api.core import vehicle_files
from api.core.sensitivity_request import AHPRequest, SensitivityRequest
from api.http.app_codes import app_router
from api.http.deps import RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import error_responses
from daq.store import ResultNotFound
from estimation.vehicle.ahp import Judgement
from estimation.vehicle.responses import RESPONSES

router = app_router("/api/analysis", "analysis")
#: Right-hand-side evaluations one simulation may cost (a typical one needs a few hundred).
MAX_EVALUATIONS = 200_000
#: A request's analysis stops (422) past this many seconds (a typical one takes 0.3 s).
TIME_LIMIT_S = 30.0


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
        request=body,
        max_evaluations=MAX_EVALUATIONS,
        time_limit_s=TIME_LIMIT_S,
    )
    try:
        return runner.analysis.executor_for(store).call(store.url, study)
    except (vehicle_files.VehicleNotFound, ResultNotFound) as err:
        raise HTTPException(404, str(err)) from None
