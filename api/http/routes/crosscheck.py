"""Cross-check routes: compare two stored estimation results (fast), or estimate runs and
compare them as a job; list stored cross-checks."""

from __future__ import annotations

import tempfile
from functools import partial
from pathlib import Path

from fastapi import Depends
from starlette.concurrency import run_in_threadpool

from api.core.crosscheck_requests import CrossCheckJobRequest, CrossCheckRequest
from api.http.app_codes import app_router
from api.http.deps import OperatorDep, RunnerDep, StoreDep, require_read, require_write
from api.http.schemas import JobOut, ResultOut, error_responses

router = app_router("/api", "crosscheck")


@router.post(
    "/crosscheck",
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 422),
)
async def crosscheck(body: CrossCheckRequest, store: StoreDep, runner: RunnerDep) -> dict:
    """Cross-check two stored estimation results (weight- vs thruster-driven, same axis):
    per coefficient both values ± σ_total, z and verdict, the diagnosis; stored as a
    ``crosscheck`` result linked to the runs of both (its id in ``result_id``; the plot at
    ``/api/results/{result_id}/report/crosscheck.png``). No fitting: fast. A pair already
    cross-checked answers that stored result (``reused: true``), never a second copy."""
    from api.core.crosscheck_job import crosscheck_results

    def work() -> dict:  # the comparison and its figure in the analysis worker process
        with tempfile.TemporaryDirectory(dir=runner.report_root) as folder:
            comparison = partial(
                crosscheck_results,
                weight_result_id=body.weight_result_id,
                thruster_result_id=body.thruster_result_id,
                report_dir=folder,
            )
            data = runner.analysis.executor_for(store).call(store.url, comparison)
            if not data.get("reused"):
                runner.adopt_report(data["result_id"], Path(folder))
        data.pop("report_files", None)
        return data

    return await run_in_threadpool(work)


@router.get(
    "/crosscheck",
    response_model=list[ResultOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def list_crosschecks(store: StoreDep) -> list[dict]:
    """Stored cross-checks, newest first."""
    return [r.to_json() for r in reversed(store.results(kind="crosscheck"))]


@router.post(
    "/jobs/crosscheck",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 404, 422),
)
def start_crosscheck_job(
    body: CrossCheckJobRequest, store: StoreDep, runner: RunnerDep, user: OperatorDep
) -> dict:
    """Estimate the weight-driven and the thruster-driven runs (each stored as an estimation)
    and cross-check them, in the estimation worker; poll the job for the result."""
    weight = [store.get_run(r).id for r in body.weight_runs]  # 404 for an unknown id, now
    thrusters = [store.get_run(r).id for r in body.thruster_runs]
    return runner.start_crosscheck(weight, thrusters, body.search_effects, user.name).to_json()
