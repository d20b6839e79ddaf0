"""A rig file (and the stored thrust calibration) as the test planner's ``RigEnvelope``."""

from __future__ import annotations

from collections.abc import Sequence

from daq.config import RigConfig
from daq.procedures.run_kinds import KINDS
from daq.store import RunInfo, Store
from estimation.design.planning_envelope import RigEnvelope

#: Time between runs that counts as tank time: carriage back, weights changed, water settling
#: (the seed campaign's ``rest_s``).
RESET_S = 30.0


def envelope_of(
    rig: RigConfig, store: Store | None = None, reset_s: float = RESET_S
) -> RigEnvelope:
    """The axes ``rig`` can test (each kind with an ``envelope`` that the rig's capabilities
    allow: tow → surge, spin → yaw), their load limits, travel and, with ``store``, the
    thrusters' calibrated range."""
    from daq.procedures.drive_check import calibrated_range

    axes = []
    for kind, spec in KINDS.items():
        if spec.envelope is None or not spec.capability(rig).available:
            continue
        span = calibrated_range(rig, store, kind) if store is not None else None
        axes.append(spec.envelope(rig, span))
    return RigEnvelope(tuple(axes), g=float(rig.rig.g), reset_s=reset_s)


def envelope_of_runs(store: Store, records: Sequence[RunInfo]) -> RigEnvelope | None:
    """The envelope of the rig the newest of the runs' ``records`` was recorded on (its
    stored rig file; ``store``: the thrusters' calibration), for the estimator's advice; None
    when no run has a readable rig file (imports)."""
    from daq.config import RigConfigError, parse_rig_text

    runs = sorted(records, key=lambda r: r.started_at)
    for run in reversed(runs):
        if not run.rig_toml:
            continue
        try:
            rig = parse_rig_text(run.rig_toml, f"run {run.id} rig file")
        except RigConfigError:
            continue
        return envelope_of(rig, store)
    return None
