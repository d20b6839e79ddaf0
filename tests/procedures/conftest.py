"""A rig session on the simulated rig (in process on simulated time in a ``simtime`` module,
else Modbus TCP + a thruster pty in real time: tests/support/simrig.py) and a temp SQLite store."""

from __future__ import annotations

from pathlib import Path

import pytest

from daq.config import RigConfig
from daq.session import RigSession, RigSource
from tests.support.simrig import rig_session
from tests.support.waiting import until

#: A short thrust calibration of the simulated rig (parameters, before the rig's checks).
QUICK_CALIBRATION = {
    "commands": [0.0, 0.1, 0.3, 0.8],
    "settle_s": 0.4,
    "samples_per_step": 3,
    "tare_samples": 5,
}


def short_rail(rig: RigConfig, end_of_travel_m: float = 0.5) -> RigConfig:
    """The BENBAM rig with the end-of-travel switch moved close, so tows end quickly."""
    geometry = rig.geometry.model_copy(update={"end_of_travel_m": end_of_travel_m})
    return rig.model_copy(update={"geometry": geometry})


#: The PLC's reply timeout of the hardware rig files these tests write, s: most of a 10 Hz
#: period, not BENBAM's 50 ms. Their "hardware" is a simulated rig on the test machine (a
#: thread of the test's process, or a `rig sim`), whose replies are as late as that machine
#: is loaded; a real PLC's are not. Under CI's load a reply came later than 50 ms and a
#: thruster tow ended, as it must, on its first unread sample ("sensor data stale or
#: unread") before the fault or the lock loss the test was about (the lease-loss test in
#: CI, the link-fault test beside a busy process).
SIMULATED_PLC_TIMEOUT_S = 0.09

#: The thruster controller's reply allowance of the rig files these tests write, s, for
#: the same reason: BENBAM's 0.1 s is a real controller's; a simulated one on a thread of a
#: loaded test process answered an ARM later than that (a 503 in a fresh-clone run).
SIMULATED_THRUSTER_ACK_S = 0.3


def _benbam_text(plc_timeout_s: float) -> str:
    """BENBAM's rig file text with the PLC's reply timeout ``plc_timeout_s``."""
    text = (Path(__file__).resolve().parents[2] / "fixtures/rigs/benbam.toml").read_text()
    assert "timeout_s = 0.05\n" in text
    return text.replace("timeout_s = 0.05\n", f"timeout_s = {plc_timeout_s}\n", 1)


def simulated_rig_file(folder: Path) -> Path:
    """BENBAM's rig file in ``folder``, simulated, with the reply allowances of a simulated
    rig on a loaded test machine (``SIMULATED_PLC_TIMEOUT_S``, ``SIMULATED_THRUSTER_ACK_S``)."""
    text = _benbam_text(SIMULATED_PLC_TIMEOUT_S)
    assert "ack_timeout_s = 0.1\n" in text
    text = text.replace("ack_timeout_s = 0.1\n", f"ack_timeout_s = {SIMULATED_THRUSTER_ACK_S}\n")
    path = folder / "benbam-simulated.toml"
    path.write_text(text)
    return path


def hardware_rig_file(
    folder: Path,
    modbus_port: int,
    thruster_port: str,
    *,
    plc_timeout_s: float = SIMULATED_PLC_TIMEOUT_S,
) -> Path:
    """BENBAM's rig file in ``folder`` with mode = "hardware", its PLC on loopback
    ``modbus_port`` (replies within ``plc_timeout_s``) and its thruster controller on
    ``thruster_port`` (a running `rig sim`, or proxies in front of one)."""
    text = _benbam_text(plc_timeout_s).replace('mode = "simulated"', 'mode = "hardware"')
    text = text.replace("port = 5020", f"port = {modbus_port}")
    text = text.replace('port = "sim"', f'port = "{thruster_port}"')
    path = folder / "hw.toml"
    path.write_text(text)
    return path


async def until_thrust_on(session: RigSession, *, timeout_s: float) -> None:
    """Until the simulated thruster controller's outputs are not all zero."""
    thrusters = session.sim.thrusters
    await until(lambda: any(thrusters.outputs), "the thrust on", timeout_s=timeout_s)


@pytest.fixture
def source() -> RigSource:
    return RigSource.load()


@pytest.fixture
async def session(source, store):
    async with rig_session(source, store) as s:
        yield s
