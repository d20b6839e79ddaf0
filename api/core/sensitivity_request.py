"""What a vehicle's sensitivity analysis takes, declared once: ``POST /api/analysis/sensitivity``'s
body (:class:`SensitivityRequest`, with :class:`AHPRequest` also ``POST /api/analysis/ahp``'s)
and ``rig sensitivity``'s options (``Flag``; the command reads ``weights`` as ``--weight
RESPONSE=W`` and ``ahp`` from a file)."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from estimation.vehicle.description import COEFFICIENT_NAMES, DOFS
from estimation.vehicle.responses import RESPONSE_NAMES

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
    responses: Annotated[
        list[str] | None,
        Field(max_length=len(RESPONSE_NAMES),
              description="Response names; default every one the vehicle can do: "
              + ", ".join(RESPONSE_NAMES)),
        Flag("--response", metavar="NAME"),
    ] = None  # fmt: skip
    weights: dict[str, Annotated[float, Field(ge=0, le=1e6)]] | None = Field(
        None, description="Response weights (renormalised); default equal. Or give ahp."
    )
    ahp: AHPRequest | None = Field(None, description="Judgement matrices over the responses.")
    thresholds: Annotated[
        list[Annotated[float, Field(gt=0, le=1e3)]],
        Field(default_factory=list, max_length=MAX_THRESHOLDS,
              description="Extra composite thresholds (added to 0.005, 0.0075, 0.01)."),
        Flag("--threshold"),
    ]  # fmt: skip
    keep: Annotated[
        list[str],
        Field(default_factory=list, max_length=len(COEFFICIENT_NAMES),
              description="Coefficients never removed, e.g. 'added_mass.surge'."),
        Flag("--keep", metavar="NAME"),
    ]  # fmt: skip
    delta: Annotated[
        float, Field(gt=0, lt=0.5, description="Relative step of S (±δ·H)."), Flag("--delta")
    ] = 0.01
    forces: dict[str, Annotated[float, Field(ge=-1e5, le=1e5)]] | None = Field(
        None,
        description="Step size per axis (N or N·m), e.g. {'surge': 20}; default half the "
        "thrusters' reach.",
    )
    distance_time_s: Annotated[
        float | None,
        Field(gt=0, le=1e5, description="t of distance_at_t, s; default 3 surge time constants."),
        Flag("--distance-time"),
    ] = None
