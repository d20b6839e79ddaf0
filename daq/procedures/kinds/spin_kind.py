"""The spin test: a constant torque about the vertical axis (weight on the drum, or thrusters)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from daq.estimators import AXIS
from daq.import_rules import ImportRules, drive_plan
from daq.procedures import requests
from daq.procedures.kind_spec import KindSpec, axis_channels, driven_label, run_motion
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind

if TYPE_CHECKING:
    from daq.config import RigConfig
    from estimation.design.planning_envelope import AxisEnvelope


def _spin_envelope(rig: RigConfig, span: tuple[float, float] | None) -> AxisEnvelope:
    from estimation.design.planning_envelope import AxisEnvelope

    geometry, limits = rig.geometry, rig.limits
    return AxisEnvelope(
        "yaw",
        max_load=float(limits.max_torque_nm or 0.0),  # a spin needs it (its ``needs``)
        travel=float(geometry.spin_max_angle_rad),
        reverse_travel=float(geometry.spin_max_angle_rad),
        max_rate=float(limits.max_yaw_rate_rad_s),
        thruster_range=span,
        drum_radius_m=geometry.spin_drum_radius_m,
    )


SPEC = KindSpec(
    kind=RunKind.SPIN,
    rank=20,
    label="spin test",
    help="Spin test: constant torque about the vertical axis (weight on the drum, or thrusters).",
    request=requests.SpinRequest,
    run=run_motion,
    describe=lambda p: driven_label("spin", p.torque_nm, "N·m", p.drive),
    command="spin",
    route="spin",
    estimator=AXIS,
    imports=ImportRules("spin angle, rad", drive_plan),
    needs=Needs(channels=axis_channels(RunKind.SPIN), settings=("limits.max_torque_nm",)),
    drives={
        "weight": Needs(settings=("geometry.spin_drum_radius_m",)),
        "thrusters": Needs(thrusters=True),
    },
    acts=("hang_spin_weight", "return_carriage", "unmount_thrust_stand"),
    envelope=_spin_envelope,
)
