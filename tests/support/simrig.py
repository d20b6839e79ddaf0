"""Rig sessions for tests: in process on simulated time in a ``simtime`` test, over real
sockets and ptys in real time otherwise.

A module marked ``pytest.mark.simtime`` runs its async tests and fixtures on
``daq.sim.simtime.SimTimeLoop`` (tests/conftest.py); ``rig_session`` then builds the
simulated rig in process (``daq.sim.inprocess``) on that loop's clock, so a 30 s tow takes a
fraction of a second and the same scenario seed gives the same samples. A synchronous
fixture records on simulated time with ``SimClock.run(coroutine)``.
"""

from __future__ import annotations

import asyncio
from typing import Any

from daq.session import RigSession, RigSource
from daq.sim.inprocess import open_inprocess_rig
from daq.sim.simtime import SimClock, SimTimeLoop
from daq.store import Store


def rig_session(source: RigSource, store: Store, **options: Any) -> RigSession:
    """A session (not yet open) on the simulated rig: in process on simulated time on a
    ``SimTimeLoop``, otherwise over Modbus TCP and a thruster pty in real time."""
    if isinstance(asyncio.get_running_loop(), SimTimeLoop):
        options |= {"clock": SimClock.of_running_loop(), "devices": open_inprocess_rig}
    return RigSession(source, store, **options)
