"""Campaign routes: start a campaign (measure until certain), watch its trail, stop it
(``api.core.campaign``; the planner: ``estimation.design``, docs/campaigns.md)."""

from __future__ import annotations

from fastapi import Depends

from api.core.campaign import CampaignRunner
from api.core.campaign_request import CampaignRequest
from api.core.job_model import JobConflict
from api.http.app_codes import app_router
from api.http.deps import OperatorDep, RunnerDep, require_read, require_write
from api.http.schemas import JobOut, error_responses

router = app_router("/api/campaigns", "campaigns")


@router.post(
    "",
    status_code=202,
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 403, 409, 422, 423, 503),
)
def start_campaign(body: CampaignRequest, runner: RunnerDep, user: OperatorDep) -> dict:
    """Start a campaign (the body is ``rig campaign``'s options, ``api.core.campaign_request``):
    each test it chooses is queued as a tow/spin job (metadata
    ``campaign``); its trail is the job's ``outcome`` (live on the stream)."""
    return CampaignRunner.of(runner).start(body, user.name).to_json()


@router.get(
    "",
    response_model=list[JobOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 503),  # 503: the jobs' database unreachable
)
def list_campaigns(runner: RunnerDep) -> list[dict]:
    """The campaigns, newest first, each with its trail."""
    return [j.to_json() for j in runner.list() if j.kind == "campaign"]


def _campaign(runner, job_id: str):
    job = runner.get(job_id)
    if job.kind != "campaign":
        raise JobConflict(f"job {job_id} is a {job.kind} job, not a campaign")
    return job


@router.get(
    "/{job_id}",
    response_model=JobOut,
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 409, 503),
)
def get_campaign(job_id: str, runner: RunnerDep) -> dict:
    """One campaign: target, budget, used, outcome, the run pending and the trail."""
    return _campaign(runner, job_id).to_json()


@router.post(
    "/{job_id}/stop",
    response_model=JobOut,
    dependencies=[Depends(require_write)],
    responses=error_responses(401, 403, 404, 409),
)
def stop_campaign(job_id: str, runner: RunnerDep) -> dict:
    """Choose no further test: a test it queued that has not started leaves the queue; one
    on the rig goes on (abort it like any job) and the campaign ends with it."""
    return CampaignRunner.of(runner).stop(job_id).to_json()
