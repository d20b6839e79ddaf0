"""A real rig session on the simulated rig (Modbus TCP + thruster pty) and a temp SQLite store."""

from __future__ import annotations

import pytest

from daq.config import RigConfig
from daq.session import RigSession, RigSource
from daq.store import Store


def short_rail(rig: RigConfig, end_of_travel_m: float = 0.5) -> RigConfig:
    """The BENBAM rig with the end-of-travel switch moved close, so tows end quickly."""
    geometry = rig.geometry.model_copy(update={"end_of_travel_m": end_of_travel_m})
    return rig.model_copy(update={"geometry": geometry})


@pytest.fixture
def store(tmp_path):
    s = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    yield s
    s.close()


@pytest.fixture
def source() -> RigSource:
    return RigSource.load()


@pytest.fixture
async def session(source, store):
    async with RigSession(source, store) as s:
        yield s
