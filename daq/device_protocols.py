"""What procedures need of the rig's devices, as small protocols (STYLE.md, section 1).

``Sampler`` (``daq.acquisition``) is what the clock polls; ``Thrusters`` is what a
procedure commands. The real ``ThrusterDriver`` over a serial line and the same driver
over an in-process link to the simulated controller (``daq.sim.inprocess``) both are one.

``DeviceFactory`` is how a ``RigSession`` gets its devices when it is not to open the
rig file's own (``RigSession(..., devices=...)``): tests build the simulated rig in
process on a simulated clock.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING, Protocol

from thrusters.driver import ThrusterDriver, ThrusterError

if TYPE_CHECKING:
    from daq.clock import Clock
    from daq.config import RigConfig
    from daq.plc import PlcClient
    from daq.sim.scenario import Scenario
    from thrusters.driver import OutputStep, ThrusterFault, ThrusterStatus
    from thrusters.settings import CommandLimits, ThrusterPort


class Thrusters(Protocol):
    """Thrusters a procedure commands, e.g. ``await thrusters.command([0.3, 0.3])``."""

    #: Why commands are held at zero (e.g. ``"sensor data stale"``), or None.
    inhibited: str | None

    @property
    def fault(self) -> ThrusterFault | None: ...  # the first since arming (link lost, watchdog)

    @property
    def confirmed(self) -> tuple[float, ...]: ...  # outputs the controller last confirmed

    async def query(self) -> ThrusterStatus: ...  # state, RPM and current per thruster

    async def command(self, fractions: Sequence[float]) -> bool: ...

    async def zero(self, retries: int = 3) -> bool: ...  # outputs to zero at once, ACKed

    async def wait_fault(self) -> ThrusterFault: ...

    def recording_outputs(self) -> AbstractContextManager[list[OutputStep]]: ...


class RigDevices(Protocol):
    """A rig's devices as a factory made them (clients not yet connected or opened)."""

    plc_client: PlcClient
    driver: ThrusterDriver | None

    def close(self) -> None: ...


#: Makes the devices of a rig on a clock: ``factory(rig, scenario, clock)``.
DeviceFactory = Callable[["RigConfig", "Scenario | None", "Clock"], RigDevices]


def open_thruster_driver(port: ThrusterPort, limits: CommandLimits) -> ThrusterDriver:
    """The driver for the rig file's ``[thrusters]``; a port that cannot be used is a
    one-line ``ThrusterError`` naming the controller and the ``thrusters.port`` setting."""
    if port.port == "sim":
        raise ThrusterError(
            "thruster controller: thrusters.port = 'sim' is only for a simulated rig; "
            "give the controller's device path or pyserial URL"
        )
    return ThrusterDriver(port, limits)
