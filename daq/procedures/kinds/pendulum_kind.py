"""The pendulum free-decay test: pull the vehicle out on the pendulum, release, record."""

from __future__ import annotations

from typing import TYPE_CHECKING

from daq.config import PENDULUM_CHANNELS
from daq.estimators import PENDULUM
from daq.import_rules import ImportRules, pendulum_plan
from daq.procedures import requests
from daq.procedures.kind_spec import KindOutcome, KindSpec
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind

if TYPE_CHECKING:
    from daq.config import RigConfig
    from estimation.design.planning_envelope import ReleaseEnvelope


async def _run_pendulum(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.pendulum import run_pendulum_decay

    return KindOutcome(await run_pendulum_decay(session, params, abort=abort, progress=progress))


def _pendulum_envelope(rig: RigConfig, span: tuple[float, float] | None) -> ReleaseEnvelope:
    """The releases the rig file allows (0 < φ₀ ≤ ``[pendulum] max_angle_rad``), a run's
    longest swing (the request's default ``max_time_s`` on this rig) and the amplitude it
    stops below (the request's default); ``span`` (thrusters) plays no part in a release."""
    from daq.procedures.params import max_time
    from estimation.design.planning_envelope import RELEASE_SMALLEST_SHARE, ReleaseEnvelope

    assert rig.pendulum is not None  # the capability asks for the [pendulum] section
    request = requests.PendulumRequest.model_fields
    largest = float(rig.pendulum.max_angle_rad)
    return ReleaseEnvelope(
        str(SPEC.axis.axis),  # type: ignore[union-attr]  # the pendulum's axis: the swing
        kind=str(SPEC.kind),
        command=str(SPEC.command),
        field="start_angle_rad",
        option="--angle",
        unit="rad",
        min_amplitude=RELEASE_SMALLEST_SHARE * largest,
        max_amplitude=largest,
        max_run_s=float(max_time(None, rig) or 120.0),
        stop_amplitude=float(request["stop_amplitude_rad"].default),
    )


SPEC = KindSpec(
    kind=RunKind.PENDULUM,
    rank=30,
    label="pendulum free-decay test",
    help="Pendulum free decay: pull the vehicle out on the pendulum, release, record the swing.",
    request=requests.PendulumRequest,
    run=_run_pendulum,
    describe=lambda p: f"pendulum {p.start_angle_rad:.3g} rad",
    command="pendulum",
    route="pendulum",
    estimator=PENDULUM,
    imports=ImportRules("pendulum angle, rad (--rig gives the geometry)", pendulum_plan),
    needs=Needs(channels=PENDULUM_CHANNELS, pendulum=True),
    acts=("mount_pendulum", "pull_pendulum"),
    shown=("start_angle_rad", "rad"),
    envelope=_pendulum_envelope,
)
