"""Which stored jobs to list: one declaration for ``GET /api/jobs`` (its query parameters,
``Annotated[JobFilter, Query()]``) and ``rig jobs`` (its options, ``request_options``), so a
filter added here is on both faces, with the same name, choices and help. The page
(``limit``, ``offset``) is ``api.core.paging.JobsPage``, on both faces too."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from daq.store.schema import JobState


class JobFilter(BaseModel):
    """Every filter optional; the jobs listed match all those given."""

    model_config = ConfigDict(defer_build=True)

    state: Annotated[
        JobState | None, Field(description="Only jobs in this state."), Flag("--state")
    ] = None
