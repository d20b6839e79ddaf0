"""Sequence files the browser can start (``POST /api/jobs/sequence`` takes a file's
``content``)."""

from __future__ import annotations

from typing import Annotated

from fastapi import Depends, HTTPException, Query

from api.core.pretest import PretestQuery, predict_sequence
from api.core.sequence_files import list_sequences, sequence_files
from api.http.app_codes import app_router
from api.http.deps import RunnerDep, ServiceDep, StoreDep, require_read
from api.http.schemas import SequenceFileOut, error_responses
from daq.procedures.params import ParameterError
from daq.store import ResultNotFound

router = app_router("/api/sequences", "jobs")


@router.get(
    "",
    response_model=list[SequenceFileOut],
    dependencies=[Depends(require_read)],
    responses=error_responses(401),
)
def get_sequences(service: ServiceDep) -> list[dict]:
    """The sequence files (``fixtures/sequences``, then ``$RIG_SEQUENCES_DIR``) with their
    steps labelled and what this rig finds wrong with each (empty ``problems``: it starts)."""
    return list_sequences(service.source.rig)


@router.get(
    "/{name}/uncertainty",
    dependencies=[Depends(require_read)],
    responses=error_responses(401, 404, 422),
)
def get_sequence_uncertainty(
    name: str,
    service: ServiceDep,
    store: StoreDep,
    runner: RunnerDep,
    query: Annotated[PretestQuery, Query()],
) -> dict:
    """Pre-test: the budget and U (95 %) each coefficient will reach if sequence ``name``
    is run (its weight-driven tows and spins simulated with the newest stored estimate of
    each axis, or ``result``, and this rig's declared tolerances; docs/uncertainty.md; the
    query is ``rig predict-uncertainty``'s options, ``api.core.pretest.PretestQuery``).
    Computed in the analysis worker process, not the rig's (about a second per axis)."""
    path = sequence_files().get(name)
    if path is None:
        raise HTTPException(404, f"no sequence file {name!r}")
    try:
        return runner.analysis.executor_for(store).call(
            store.url,
            predict_sequence,
            service.source.rig,
            path,
            query.result,
            query.release_std_s,
        )
    except ResultNotFound as err:
        raise HTTPException(404, str(err)) from None
    except (ValueError, ParameterError) as err:
        raise HTTPException(422, str(err)) from None
