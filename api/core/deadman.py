"""A dead-man on a running procedure job: the page that started it says it is still there
(``POST /api/jobs/{id}/alive``) at least every ``within_s``; when it stops (the tab closed,
the network gone, the browser hung) the job is aborted, and its procedure's ending leaves
the thrusters at zero and the brake engaged, as every abort does.

The checks run on the rig loop (where a job's abort signal lives), so an expiry never waits
on an HTTP thread; the silence is timed on the host's clock. A job never kept alive has no
dead-man (the CLI, a scripted client: their own Ctrl-C and the run's bounded duration stop
it).
"""

from __future__ import annotations

import asyncio
import math
import time

from api.core.job_model import Job, JobConflict
from api.core.jobs import JobRunner
from api.core.rig_worker import PROCEDURES
from daq.store.schema import JOB_FINAL

#: Longest silence from the page before its job is aborted, s (it says so every second).
DEADMAN_S = 3.0

#: Per job id: when the page last said it is there (host monotonic time, s), and the pending
#: check of its silence (rig loop only).
_heard: dict[str, float] = {}
_checks: dict[str, asyncio.TimerHandle] = {}
#: Shortest wait between two checks of one job's silence, s.
MIN_CHECK_S = 0.1


def keep_alive(runner: JobRunner, job_id: str, within_s: float = DEADMAN_S) -> Job:
    """Abort procedure job ``job_id`` unless this is called again within ``within_s``;
    409 for a job that ended or is not a procedure."""
    job = runner.get(job_id)
    if job.kind not in PROCEDURES:
        raise JobConflict(f"job {job.id} is a {job.kind}; only procedures have a dead-man")
    if job.state in JOB_FINAL:
        raise JobConflict(f"job {job.id} already ended ({job.state})")
    runner.service.call_soon(_heard_from, job, within_s, time.monotonic())
    return job


def _heard_from(job: Job, within_s: float, at: float) -> None:
    """On the rig loop: the page spoke at ``at``; check its silence ``within_s`` later."""
    _heard[job.id] = max(at, _heard.get(job.id, at))
    if job.id not in _checks:
        _check_later(job, within_s, within_s)


def _check_later(job: Job, within_s: float, delay_s: float) -> None:
    loop = asyncio.get_running_loop()
    _checks[job.id] = loop.call_later(max(delay_s, MIN_CHECK_S), _check, job, within_s)


def _check(job: Job, within_s: float) -> None:
    """On the rig loop: abort the job if its page has been silent ``within_s`` or more. The
    silence is measured on the host's clock, the network's time: a simulated rig's loop
    may run faster than it (tests), so a check that comes early looks again."""
    _checks.pop(job.id, None)
    silent = time.monotonic() - _heard.get(job.id, -math.inf)
    if job.state in JOB_FINAL or job.abort is None:
        _heard.pop(job.id, None)
    elif silent >= within_s:
        _heard.pop(job.id, None)
        job.abort.set(f"dead-man: the page that started it fell silent for {within_s:g} s")
    else:
        _check_later(job, within_s, within_s - silent)
