"""A procedure job's request → its validated parameters and label, so a queued job can be
rebuilt from the request stored with it (after a restart) exactly as the route built it."""

from __future__ import annotations

from typing import Any

from daq.procedures.params import (
    calibration_parameters,
    pendulum_parameters,
    spin_parameters,
    tow_parameters,
)
from daq.procedures.sequence import parse_sequence


def procedure_from_request(kind: str, request: dict[str, Any], rig: Any) -> tuple[Any, str]:
    """``(parameters, label)`` of a ``kind`` job asked for with ``request`` (the JSON body);
    ``ParameterError`` / ``ValueError`` name the bad field. The request's ``metadata`` is
    for the runs, not the procedure (:meth:`JobRunner.start_procedure` checks it)."""
    request = {k: v for k, v in request.items() if k != "metadata"}
    if kind == "tow":
        params = tow_parameters(request, rig)
        drive = " (thrusters)" if params.drive == "thrusters" else ""
        return params, f"tow {params.force_n:.4g} N{drive}"
    if kind == "spin":
        params = spin_parameters(request, rig)
        drive = " (thrusters)" if params.drive == "thrusters" else ""
        return params, f"spin {params.torque_nm:.4g} N·m{drive}"
    if kind == "pendulum":
        params = pendulum_parameters(request, rig)
        return params, f"pendulum {params.start_angle_rad:.3g} rad"
    if kind == "thrust_calibration":
        return calibration_parameters(request, rig), "thrust calibration"
    if kind == "sequence":
        seq = parse_sequence(request, rig, source="api")
        return seq, f"sequence {seq.name} ({len(seq.steps) * seq.repeats} runs)"
    raise ValueError(f"kind: {kind!r} is not a procedure")
