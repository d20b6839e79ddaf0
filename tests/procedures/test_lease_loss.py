"""Losing the lease is a fault like losing the PLC.

Session A drives a thruster tow on a hardware rig file whose devices are a simulated rig's
(in this process, so the controller's outputs and the brake coil are seen as they change)
and records to PostgreSQL. Its lock connection is terminated mid-tow
(``pg_terminate_backend``): the thrusters must be at zero and the brake engaged within
0.5 s, A's run ``aborted`` naming the lost lock, A's devices released, and a session B on
the same devices may then open.
"""

from __future__ import annotations

import asyncio
import gc
import time
from pathlib import Path

import pytest
import sqlalchemy as sa

from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.operator import OperatorAct, SimulatedOperator
from daq.procedures.motion import run_motion_test
from daq.procedures.requests import calibration_parameters, tow_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.session import RigSession, RigSource
from daq.sim.simtime import SimClock
from daq.sim.simulated_rig import SimulatedRigThread
from daq.store import Store
from tests.procedures.conftest import QUICK_CALIBRATION, hardware_rig_file
from tests.procedures.test_thruster_link_faults import OutputLog
from tests.support.simrig import rig_session
from tests.support.waiting import until

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

#: Longest time from the loss of the lock to zero thrust and the brake on (issue 19).
SAFE_WITHIN_S = 0.5


class PlayedOperator:
    """The operator's acts played on the simulator through the session's own PLC client
    (the rig file says hardware, so nobody else would)."""

    def __init__(self) -> None:
        self.session: RigSession | None = None

    async def perform(self, act: OperatorAct) -> None:
        assert self.session is not None
        await SimulatedOperator(self.session.live_plc).perform(act)


async def _calibrate(url: str) -> None:
    with Store(url) as store:
        async with rig_session(RigSource.load(), store) as session:
            params = calibration_parameters(QUICK_CALIBRATION, session.rig)
            outcome, _ = await run_thrust_calibration(session, params)
            assert outcome.status == "completed"


@pytest.fixture
def pg_url(postgres_server):
    """A fresh PostgreSQL database holding one thrust calibration of the simulated rig,
    recorded in process on simulated time (tests/support/simrig.py): the thruster tow's set-up,
    not what is tested here."""
    url = postgres_server.create_database()
    SimClock.run(_calibrate(url))
    gc.collect()  # the set-up's garbage goes now, not in a full collection mid-tow
    yield url
    postgres_server.drop_database(url)


@pytest.fixture
def simulated_devices(tmp_path) -> tuple[SimulatedRigThread, Path]:
    """A simulated rig standing in for the hardware, and a hardware rig file pointing at it."""
    with SimulatedRigThread(load_rig(DEFAULT_RIG_FILE)) as sim:
        ends = sim.endpoints
        yield sim, hardware_rig_file(tmp_path, ends.port, ends.thruster_serial_port)


def _session(rig_file: Path, store: Store, owner: str) -> RigSession:
    operator = PlayedOperator()
    session = RigSession(RigSource.load(rig_file), store, operator=operator, owner=owner)
    operator.session = session
    return session


async def test_a_terminated_lock_connection_stops_the_tow_and_frees_the_rig(
    simulated_devices, pg_url, postgres_server
):
    sim, rig_file = simulated_devices
    with Store(pg_url) as store:
        a = _session(rig_file, store, "service A")
        async with a:
            outputs = OutputLog(sim)
            tow = tow_parameters(
                {"force_n": 15.0, "drive": "thrusters", "max_time_s": 30, "baseline_s": 0.3},
                a.rig,
            )
            running = asyncio.ensure_future(run_motion_test(a, tow))

            def thrust_on_and_released() -> bool:
                assert not running.done(), f"A's tow ended before its thrust: {running.result()}"
                return outputs.thrust_on() and sim.plant.tow_release

            await until(thrust_on_and_released, "A's thrust on, its brake released")
            backend = a.rig_lock.pg.backend_pid
            with sa.create_engine(postgres_server.admin_url).connect() as admin:
                # the lock is lost when its connection is terminated, not while this test
                # opens its own admin connection (a new engine and a login)
                t_lost = time.monotonic()
                admin.execute(sa.text("SELECT pg_terminate_backend(:p)"), {"p": backend})
            await until(
                lambda: outputs.zero_after(t_lost) is not None and not sim.plant.tow_release,
                "A's thrust zero and its brake on",
                timeout_s=5,
                poll_s=0.002,
            )
            t_braked = time.monotonic()
            t_zero = outputs.zero_after(t_lost)
            assert t_zero - t_lost < SAFE_WITHIN_S, f"thrust zero {t_zero - t_lost:.3f} s after"
            assert t_braked - t_lost < SAFE_WITHIN_S, f"brake on {t_braked - t_lost:.3f} s after"
            print(
                f"thrust zero {t_zero - t_lost:.3f} s, brake on ≤ {t_braked - t_lost:.3f} s "
                "after pg_terminate_backend"
            )
            ended = await asyncio.wait_for(running, 30)
            await asyncio.wait_for(a.released.wait(), 10)
            assert ended.status == "aborted"
            assert ended.reason.startswith("rig lock lost: the PostgreSQL connection holding it")
            run = store.get_run(ended.run_id)
            assert (run.status, run.reason) == ("aborted", ended.reason)
            faults = [e for e in store.events(ended.run_id) if e.kind == "fault"]
            assert any("rig lock lost" in e.message for e in faults), faults
            assert store.sample_count(ended.run_id) > 0  # what it recorded is kept
            # A released its devices: the thruster line and the lease are free for B.
            assert not a.rig_lock.held and not a.thrusters.is_open
            assert sim.thrusters.outputs == [0.0] * a.rig.thrusters.count

            b = _session(rig_file, store, "service B")
            async with b:
                assert b.rig_lock.held
                weight = tow_parameters({"force_n": 24.5, "max_time_s": 1.0}, b.rig)
                assert (await run_motion_test(b, weight)).status == "completed"
