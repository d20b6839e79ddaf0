"""The pendulum free-decay test: pull the vehicle out on the pendulum, release, record."""

from __future__ import annotations

from daq.config import PENDULUM_CHANNELS
from daq.estimators import PENDULUM
from daq.import_rules import ImportRules, pendulum_plan
from daq.procedures import requests
from daq.procedures.kind_spec import KindOutcome, KindSpec
from daq.rig_capabilities import Needs
from daq.vocabulary import RunKind


async def _run_pendulum(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.pendulum import run_pendulum_decay

    return KindOutcome(await run_pendulum_decay(session, params, abort=abort, progress=progress))


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
)
