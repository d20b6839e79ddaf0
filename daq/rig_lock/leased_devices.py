"""What a rig's lease is on: the devices its rig file points at.

A device is named by where it is reached, not by the rig's name or the database:

* a PLC over Modbus TCP — its address (the host name resolved to an IP address), TCP port
  and unit id: ``PLC tcp 10.0.0.5:502 unit 1``;
* a PLC over Modbus RTU, or a thruster controller — its serial port, symlinks resolved
  (``/dev/serial/by-id/…`` and ``/dev/ttyUSB0`` are one port); a pyserial URL to another
  host (``socket://10.0.0.7:7000``, ``rfc2217://…``) by its address like a TCP PLC.

A loopback address or a local serial port names a device of *this* host only, so its name
carries the host name (``… on host lab-pc``): two hosts' ``/dev/ttyUSB0`` are different
devices. Two rig files that share a device (one PLC, two register maps) share its lease.

A **simulated rig** has no shared devices: each session starts its own simulator on ports
of its own, so its lease is on that simulator alone (named by host, pid and a per-process
session number) and never refuses another session; it still goes through the same lease
(taken before the simulator starts, renewed, released) so the code path is the one real
rigs use.
"""

from __future__ import annotations

import hashlib
import ipaddress
import itertools
import os
import socket
from dataclasses import dataclass
from typing import TYPE_CHECKING
from urllib.parse import urlsplit

if TYPE_CHECKING:
    from daq.config import RigConfig

_SIMULATED_SESSIONS = itertools.count(1)


@dataclass(frozen=True)
class Device:
    """One device a lease covers: ``what`` (``PLC``) and where it is (``tcp 10.0.0.5:502
    unit 1``); ``key`` is the canonical text every process derives the same way."""

    what: str
    where: str

    @property
    def key(self) -> str:
        return f"{self.what} {self.where}"

    def digest(self) -> bytes:
        """SHA-256 of the key: lock file, socket name and advisory-lock key come from it."""
        return hashlib.sha256(self.key.encode()).digest()

    def __str__(self) -> str:
        return self.key


def rig_devices(rig: RigConfig) -> list[Device]:
    """The devices of ``rig`` (see the module docstring), PLC first."""
    here = socket.gethostname()
    if rig.rig.mode == "simulated":
        session = next(_SIMULATED_SESSIONS)
        return [Device("simulated rig", f"of pid {os.getpid()} on host {here}, #{session}")]
    bus = rig.modbus
    if bus.transport == "tcp":
        address, local = _network_address(bus.host)
        where = f"tcp {address}:{bus.port} unit {bus.unit_id}"
        devices = [Device("PLC", f"{where} on host {here}" if local else where)]
    else:
        devices = [Device("PLC", f"rtu {_serial_port(bus.serial_port or '', here)}")]
    if rig.thrusters is not None:
        devices.append(Device("thruster controller", _serial_port(rig.thrusters.port, here)))
    return devices


def _network_address(host: str) -> tuple[str, bool]:
    """``host`` as an IP address (as resolved now; the name if it does not resolve), and
    whether it is a loopback address (a device of this host only)."""
    try:
        address = str(socket.getaddrinfo(host, None, proto=socket.IPPROTO_TCP)[0][4][0])
    except (OSError, UnicodeError, IndexError):
        address = host.casefold()
    try:
        local = ipaddress.ip_address(address).is_loopback
    except ValueError:
        local = address == "localhost"
    return address, local


def _serial_port(port: str, here: str) -> str:
    """A device path (symlinks resolved) on this host, or a pyserial URL's address."""
    if "://" in port:
        url = urlsplit(port)
        if url.hostname:
            address, local = _network_address(url.hostname)
            where = f"{url.scheme}://{address}:{url.port}"
            return f"{where} on host {here}" if local else where
        return port
    return f"{os.path.realpath(port)} on host {here}"
