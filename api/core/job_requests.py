"""A procedure job's request → its validated parameters and label, so a queued job can be
rebuilt from the request stored with it (after a restart) exactly as the route built it."""

from __future__ import annotations

from typing import Any

from daq.procedures.kinds import KINDS
from daq.procedures.sequence import parse_sequence


def procedure_from_request(kind: str, request: dict[str, Any], rig: Any) -> tuple[Any, str]:
    """``(parameters, label)`` of a ``kind`` job asked for with ``request`` (the JSON body);
    ``ParameterError`` / ``ValueError`` name the bad field. The request's ``metadata`` is
    for the runs, not the procedure (:meth:`JobRunner.start_procedure` checks it)."""
    request = {k: v for k, v in request.items() if k != "metadata"}
    if kind == "sequence":
        seq = parse_sequence(request, rig, source="api")
        return seq, f"sequence {seq.name} ({len(seq.steps) * seq.repeats} runs)"
    spec = KINDS.get(kind)
    if spec is None:
        raise ValueError(f"kind: {kind!r} is not a procedure")
    params = spec.check(request, rig)
    return params, spec.describe(params)
