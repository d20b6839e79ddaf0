"""A dead-man on a running procedure job: the page that started it says it is still there
(``POST /api/jobs/{id}/alive``) at least every ``within_s``; when it stops (the tab closed,
the network gone, the browser hung) the job is aborted, and its procedure's ending leaves
the thrusters at zero and the brake engaged, as every abort does.

The timers live on the rig loop (where a job's abort signal lives), so an expiry never
waits on an HTTP thread; a job never kept alive has no dead-man (the CLI, a scripted
client: their own Ctrl-C and the run's bounded duration stop it).
"""

from __future__ import annotations

import asyncio

from api.core.job_model import Job, JobConflict
from api.core.jobs import JobRunner
from api.core.rig_worker import PROCEDURES
from daq.store.schema import JOB_FINAL

#: Longest silence from the page before its job is aborted, s (it says so every second).
DEADMAN_S = 3.0

#: Per job id, the pending abort (rig loop only).
_timers: dict[str, asyncio.TimerHandle] = {}


def keep_alive(runner: JobRunner, job_id: str, within_s: float = DEADMAN_S) -> Job:
    """Abort procedure job ``job_id`` unless this is called again within ``within_s``;
    409 for a job that ended or is not a procedure."""
    job = runner.get(job_id)
    if job.kind not in PROCEDURES:
        raise JobConflict(f"job {job.id} is a {job.kind}; only procedures have a dead-man")
    if job.state in JOB_FINAL:
        raise JobConflict(f"job {job.id} already ended ({job.state})")
    runner.service.call_soon(_rearm, job, within_s)
    return job


def _rearm(job: Job, within_s: float) -> None:
    """On the rig loop: push the job's abort ``within_s`` into the future."""
    pending = _timers.pop(job.id, None)
    if pending is not None:
        pending.cancel()
    if job.state not in JOB_FINAL:
        loop = asyncio.get_running_loop()
        _timers[job.id] = loop.call_later(within_s, _expired, job, within_s)


def _expired(job: Job, within_s: float) -> None:
    """On the rig loop: the page fell silent; abort the job (if it still runs)."""
    _timers.pop(job.id, None)
    if job.state not in JOB_FINAL and job.abort is not None:
        job.abort.set(f"dead-man: the page that started it fell silent for {within_s:g} s")
