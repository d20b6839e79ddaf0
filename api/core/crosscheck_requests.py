"""What a cross-check takes, declared once: two stored results (:class:`CrossCheckRequest`,
``POST /api/crosscheck``'s body) or two sets of runs to estimate first
(:class:`CrossCheckJobRequest`, ``POST /api/jobs/crosscheck``'s); ``rig crosscheck``'s
options are derived from both (``Flag``)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from daq.procedures.flag import Flag
from daq.procedures.requests import StrictRequest


class CrossCheckRequest(StrictRequest):
    """Two stored estimation results of one axis: weight-driven and thruster-driven."""

    weight_result_id: Annotated[
        int,
        Field(ge=1, le=2**53, description="Estimation result of weight-driven runs."),
        Flag("--weight-result", metavar="ID"),
    ]
    thruster_result_id: Annotated[
        int,
        Field(ge=1, le=2**53, description="Estimation result of thruster-driven runs."),
        Flag("--thruster-result", metavar="ID"),
    ]


class CrossCheckJobRequest(StrictRequest):
    """Weight-driven and thruster-driven runs of one axis, estimated and cross-checked."""

    weight_runs: Annotated[
        list[str],
        Field(min_length=1, max_length=50, description="Weight-driven runs (ids or prefixes)."),
        Flag("--weight", metavar="RUN"),
    ]
    thruster_runs: Annotated[
        list[str],
        Field(min_length=1, max_length=50, description="Thruster-driven runs (ids or prefixes)."),
        Flag("--thrusters", metavar="RUN"),
    ]
    search_effects: Annotated[
        bool,
        Field(description="Search the weight-driven runs for effects the base model lacks."),
        Flag("--no-effects", when_set=False, help="Estimate the base model only."),
    ] = True
