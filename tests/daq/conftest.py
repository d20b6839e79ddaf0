"""Fixtures of the driver tests: a register-map PLC on a real socket and a client of it."""

from __future__ import annotations

from collections.abc import AsyncIterator
from typing import Any

import pytest

from daq.config import load_rig
from daq.plc import PlcClient
from tests.daq.modbus_server import MapServer


@pytest.fixture
async def server() -> AsyncIterator[MapServer]:
    """BENBAM's register map served over Modbus TCP on a free loopback port."""
    srv = MapServer(load_rig())
    await srv.start()
    yield srv
    await srv.stop()


@pytest.fixture
def plc_modbus() -> dict[str, Any]:
    """[modbus] overrides of the ``plc`` fixture's client (a module overrides this)."""
    return {}


@pytest.fixture
async def plc(server: MapServer, plc_modbus: dict[str, Any]) -> AsyncIterator[PlcClient]:
    """A connected ``PlcClient`` of ``server``."""
    client = PlcClient(server.rig_config(**plc_modbus))
    await client.connect(timeout_s=2.0)
    yield client
    await client.close()
