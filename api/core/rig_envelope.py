"""A rig file (and the stored thrust calibration) as the test planner's ``RigEnvelope``."""

from __future__ import annotations

from daq.config import RigConfig
from daq.procedures.kinds import KINDS
from daq.store import Store
from estimation.design.envelope import AxisEnvelope, RigEnvelope

#: Time between runs that counts as tank time: carriage back, weights changed, water settling
#: (the seed campaign's ``rest_s``).
RESET_S = 30.0


def envelope_of(
    rig: RigConfig, store: Store | None = None, reset_s: float = RESET_S
) -> RigEnvelope:
    """The axes ``rig`` can test (tow → surge, spin → yaw, as its capabilities say), their
    load limits, travel and, with ``store``, the thrusters' calibrated range."""
    from daq.procedures.drive_check import calibrated_range

    geometry, limits = rig.geometry, rig.limits
    axes = []
    for kind in ("tow", "spin"):
        spec = KINDS.get(kind)  # type: ignore[call-overload]
        if spec is None or not _capable(spec, rig):
            continue
        span = calibrated_range(rig, store, kind) if store is not None else None
        if kind == "tow":
            axes.append(
                AxisEnvelope(
                    "surge",
                    max_load=float(limits.max_force_n),
                    travel=float(geometry.end_of_travel_m),
                    reverse_travel=float(geometry.reverse_travel),
                    max_rate=float(limits.max_speed_m_s),
                    thruster_range=span,
                )
            )
        else:
            axes.append(
                AxisEnvelope(
                    "yaw",
                    max_load=float(limits.max_torque_nm or 0.0),  # spins need it (KINDS)
                    travel=float(geometry.spin_max_angle_rad),
                    reverse_travel=float(geometry.spin_max_angle_rad),
                    max_rate=float(limits.max_yaw_rate_rad_s),
                    thruster_range=span,
                    drum_radius_m=geometry.spin_drum_radius_m,
                )
            )
    return RigEnvelope(tuple(axes), g=float(rig.rig.g), reset_s=reset_s)


def _capable(spec: object, rig: RigConfig) -> bool:
    return bool(spec.capability(rig).available)  # type: ignore[attr-defined]


def envelope_of_runs(store: Store, run_ids: list[str]) -> RigEnvelope | None:
    """The envelope of the rig the newest of ``run_ids`` was recorded on (its stored rig
    file), for the estimator's advice; None when no run has a readable rig file (imports)."""
    import tomllib

    from daq.config import RigConfigError, parse_rig

    runs = sorted((store.get_run(r) for r in run_ids), key=lambda r: r.started_at)
    for run in reversed(runs):
        if not run.rig_toml:
            continue
        try:
            rig = parse_rig(tomllib.loads(run.rig_toml), f"run {run.id} rig file")
        except (RigConfigError, tomllib.TOMLDecodeError):
            continue
        return envelope_of(rig, store)
    return None
