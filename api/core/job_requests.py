"""A procedure job's request → its validated parameters and label, so a queued job can be
rebuilt from the request stored with it (after a restart) exactly as the route built it."""

from __future__ import annotations

from typing import Any

from daq.procedures.drive_check import check_steps, check_thruster_drive
from daq.procedures.run_kinds import RIG_KINDS
from daq.procedures.sequence import parse_sequence
from daq.store import Store


def procedure_from_request(
    kind: str, request: dict[str, Any], rig: Any, store: Store | None = None
) -> tuple[Any, str]:
    """``(parameters, label)`` of a ``kind`` job asked for with ``request`` (the JSON body);
    ``ParameterError`` / ``ValueError`` name the bad field (``steps[i].field`` in a
    sequence). With ``store``, a thruster drive (every step's) is also checked against the
    stored thrust calibration, as it will be when it starts. The request's ``metadata`` is
    for the runs, not the procedure (:meth:`JobRunner.start_procedure` checks it)."""
    request = {k: v for k, v in request.items() if k != "metadata"}
    if kind == "sequence":
        seq = parse_sequence(request, rig, source="api")
        if store is not None:
            check_steps(seq.steps, rig, store)
        return seq, f"sequence {seq.name} ({len(seq.steps) * seq.repeats} runs)"
    spec = RIG_KINDS.get(kind)
    if spec is None:
        raise ValueError(f"kind: {kind!r} is not a procedure")
    params = spec.check(request, rig)
    if store is not None:
        check_thruster_drive(params, rig, store)
    return params, spec.describe(params)
