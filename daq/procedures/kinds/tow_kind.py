"""The tow test: a weight over the pulley (or the thrusters) pulls the vehicle along the rail."""

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


def _tow_envelope(rig: RigConfig, span: tuple[float, float] | None) -> AxisEnvelope:
    from estimation.design.planning_envelope import AxisEnvelope

    geometry, limits = rig.geometry, rig.limits
    return AxisEnvelope(
        "surge",
        max_load=float(limits.max_force_n),
        travel=float(geometry.end_of_travel_m),
        reverse_travel=float(geometry.reverse_travel),
        max_rate=float(limits.max_speed_m_s),
        thruster_range=span,
    )


SPEC = KindSpec(
    kind=RunKind.TOW,
    rank=10,
    label="tow test",
    help="Tow test: a weight over the pulley (or the thrusters) pulls the vehicle along the rail.",
    request=requests.TowRequest,
    run=run_motion,
    describe=lambda p: driven_label("tow", p.force_n, "N", p.drive),
    command="tow",
    route="tow",
    estimator=AXIS,
    imports=ImportRules("tow position, m", drive_plan),
    needs=Needs(channels=axis_channels(RunKind.TOW)),
    drives={"weight": Needs(), "thrusters": Needs(thrusters=True)},
    acts=("hang_tow_weight", "return_carriage", "unmount_thrust_stand"),
    envelope=_tow_envelope,
)
