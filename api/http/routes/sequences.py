"""Sequence files the browser can start (``POST /api/jobs/sequence`` takes a file's
``content``)."""

from __future__ import annotations

from fastapi import APIRouter, Depends

from api.core.sequence_files import list_sequences
from api.http.deps import ServiceDep, require_read
from api.http.schemas import SequenceFileOut, error_responses

router = APIRouter(prefix="/api/sequences", tags=["jobs"])


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
