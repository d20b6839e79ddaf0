"""The whole simulated rig: plant + simulated PLC (Modbus) + thruster controller (serial).

``SimulatedRig`` runs on the caller's asyncio loop; ``SimulatedRigThread`` runs it in
a background thread with its own loop, so the simulator never shares the acquisition
clock's loop (procedures, the CLI and the benchmarks use the thread runner)::

    with SimulatedRigThread(load_rig()) as sim:
        rig = sim.connection_rig()        # [modbus] and [thrusters] point at the simulator
        sim.call(lambda s: setattr(s.plc.faults, "drop", True))
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from daq.config import RigConfig
from daq.sim.device_loop import DeviceLoop
from daq.sim.plant import Plant
from daq.sim.plc_server import SimulatedPLC
from daq.sim.scenario import Scenario
from thrusters.emulator import ThrusterControllerEmulator


@dataclass(frozen=True)
class SimEndpoints:
    """Where the running simulator listens."""

    modbus_transport: str  # "tcp" or "rtu"
    host: str | None  # Modbus TCP host (None for RTU)
    port: int | None  # Modbus TCP port (None for RTU)
    serial_port: str | None  # Modbus RTU device path or socket:// URL (None for TCP)
    unit_id: int
    thruster_serial_port: str | None  # pty device path or socket:// URL (None: no [thrusters])
    thruster_baudrate: int | None
    thruster_count: int

    def as_dict(self) -> dict[str, Any]:
        """Plain dictionary (JSON-ready)."""
        return asdict(self)


class SimulatedRig:
    """Plant, simulated PLC and simulated thruster controller wired together.

    ``rtu=True`` serves Modbus RTU on a pty; ``rtu="socket"`` serves RTU framing over
    TCP for a pyserial ``socket://`` URL. ``thruster_transport`` is ``"pty"`` or ``"tcp"``.
    """

    def __init__(
        self,
        rig: RigConfig,
        scenario: Scenario | None = None,
        *,
        modbus_port: int = 0,
        host: str = "127.0.0.1",
        rtu: bool | str = False,
        thruster_transport: str = "pty",
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if rtu not in (False, True, "pty", "socket"):
            raise ValueError(f"rtu: must be False, True/'pty' or 'socket', got {rtu!r}")
        if thruster_transport not in ("pty", "tcp"):
            raise ValueError(
                f"thruster_transport: must be 'pty' or 'tcp', got {thruster_transport!r}"
            )
        self.rig = rig
        self.scenario = scenario or Scenario()
        self.clock = clock
        self.plant = Plant(rig, self.scenario)
        self.plc = SimulatedPLC(rig, self.plant, clock=clock)
        #: The thruster controller (``None`` for a rig file without [thrusters]).
        self.thrusters = (
            ThrusterControllerEmulator(
                rig.thrusters.count, on_outputs=self._on_outputs, telemetry=self._telemetry
            )
            if rig.thrusters is not None
            else None
        )
        self.modbus_port = modbus_port
        self.host = host
        self.rtu_mode = "pty" if rtu is True else rtu
        self._thruster_transport = thruster_transport
        self.endpoints: SimEndpoints | None = None

    def _on_outputs(self, fractions: list[float]) -> None:
        self.plant.advance_to(self.clock())
        self.plant.set_commands(list(fractions))

    def _telemetry(self) -> list[tuple[float, float]]:
        self.plant.advance_to(self.clock())
        return self.plant.telemetry()

    async def start(self) -> SimEndpoints:
        """Start the plant clock, the Modbus server and the thruster controller."""
        self.plant.advance_to(self.clock())
        host = port = serial = None
        try:
            if self.rtu_mode == "pty":
                serial = await self.plc.start_rtu_pty()
            elif self.rtu_mode == "socket":
                serial = await self.plc.start_rtu_tcp(self.host, self.modbus_port)
            else:
                host = self.host
                port = await self.plc.start_tcp(self.host, self.modbus_port)
            thr_port = None
            if self.thrusters is None:
                pass
            elif self._thruster_transport == "tcp":
                thr_port = await self.thrusters.start_tcp(self.host)
            else:
                thr_port = await self.thrusters.start_pty()
        except BaseException:
            await self.stop()
            raise
        self.endpoints = SimEndpoints(
            modbus_transport="tcp" if host else "rtu",
            host=host,
            port=port,
            serial_port=serial,
            unit_id=self.rig.modbus.unit_id,
            thruster_serial_port=thr_port,
            thruster_baudrate=self.rig.thrusters.baudrate if self.rig.thrusters else None,
            thruster_count=self.rig.thrusters.count if self.rig.thrusters else 0,
        )
        return self.endpoints

    async def stop(self) -> None:
        """Stop serving; thrusters go to zero and both brakes engage."""
        self.plant.set_commands([0.0] * self.plant.thruster_port.count)
        self.plant.engage_tow_brake()
        self.plant.engage_spin_brake()
        await self.plc.stop()
        if self.thrusters is not None:
            await self.thrusters.stop()

    def connection_rig(self) -> RigConfig:
        """The rig config with [modbus] and [thrusters] pointing at this simulator."""
        ep = self.endpoints
        if ep is None:
            raise RuntimeError("the simulated rig is not started")
        if ep.modbus_transport == "tcp":
            modbus = {"transport": "tcp", "host": ep.host, "port": ep.port}
        else:
            modbus = {"transport": "rtu", "serial_port": ep.serial_port}
        update: dict[str, Any] = {"modbus": self.rig.modbus.model_copy(update=modbus)}
        if self.rig.thrusters is not None:
            update["thrusters"] = self.rig.thrusters.model_copy(
                update={"port": ep.thruster_serial_port}
            )
        return self.rig.model_copy(update=update)


class SimulatedRigThread:
    """A SimulatedRig running in a background thread with its own asyncio loop.

    Starts on construction (or ``with``); ``endpoints`` and ``connection_rig()`` tell
    clients where to connect; ``call(fn, *args)`` runs ``fn(*args)`` on the simulator's
    loop and returns its result (awaiting it if it is awaitable). With a single
    argument-less callable taking the rig, pass the rig: ``sim.call(fn, sim.sim)``.
    """

    def __init__(self, rig: RigConfig, scenario: Scenario | None = None, **kwargs: Any) -> None:
        self.sim = SimulatedRig(rig, scenario, **kwargs)
        # it stands in for devices with their own CPU (``device_loop``)
        self._device = DeviceLoop("simulated-rig")
        try:
            self.endpoints: SimEndpoints = self._device.submit(self.sim.start).result(10.0)
        except BaseException:
            self._device.close()
            raise

    @property
    def plant(self) -> Plant:
        return self.sim.plant

    @property
    def plc(self) -> SimulatedPLC:
        return self.sim.plc

    @property
    def thrusters(self) -> ThrusterControllerEmulator | None:
        return self.sim.thrusters

    def connection_rig(self) -> RigConfig:
        """The rig config pointing at the running simulator."""
        return self.sim.connection_rig()

    def call(self, fn: Callable[..., Any], *args: Any, timeout: float | None = 10.0) -> Any:
        """Run ``fn(*args)`` on the simulator's loop (await it if awaitable); return its result.

        A one-parameter function called without arguments gets the SimulatedRig, e.g.
        ``sim.call(lambda s: s.plc.stop_server())``.
        """
        if not args and takes_one_argument(fn):
            args = (self.sim,)
        return self._device.submit(fn, *args).result(timeout)

    def close(self) -> None:
        """Stop the simulated rig and its thread (idempotent)."""
        if self._device.running:
            try:
                self._device.submit(self.sim.stop).result(10.0)
            finally:
                self._device.close()

    def __enter__(self) -> SimulatedRigThread:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def takes_one_argument(fn: Callable[..., Any]) -> bool:
    """Whether ``fn`` takes exactly one required positional argument."""
    try:
        params = inspect.signature(fn).parameters.values()
    except (TypeError, ValueError):
        return False
    required = [
        p
        for p in params
        if p.default is p.empty and p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
    ]
    return len(required) == 1
