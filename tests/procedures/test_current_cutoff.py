"""The thrusters' current cut-off on the simulated rig: a rig file declaring
``thrusters.max_current_a`` stops a test whose thrusters draw more, with the thrusters at
zero and the reason naming the thruster, its current and the limit."""

from __future__ import annotations

import pytest

from daq.procedures.requests import calibration_parameters
from daq.procedures.thrust_calibration import run_thrust_calibration
from daq.session import RigSource
from tests.procedures.conftest import QUICK_CALIBRATION
from tests.support.simrig import rig_session

pytestmark = pytest.mark.simtime


@pytest.fixture
def limited(source: RigSource) -> RigSource:
    """BENBAM with a 2 A cut-off: the simulated thrusters draw 0.35 A at command 0.1 and
    2.4 A at 0.3 (12 A × (F/40 N)^1.5)."""
    port = source.rig.thruster_port().model_copy(update={"max_current_a": 2.0})
    return RigSource(
        rig=source.rig.model_copy(update={"thrusters": port}), rig_toml=source.rig_toml
    )


async def test_a_current_over_the_cut_off_stops_the_test_with_its_reason(limited, store):
    async with rig_session(limited, store) as session:
        params = calibration_parameters(QUICK_CALIBRATION, session.rig)
        outcome, calibration = await run_thrust_calibration(session, params)
        assert outcome.status == "aborted" and calibration is None
        assert "over the safety cut-off thrusters.max_current_a = 2 A" in outcome.reason
        assert outcome.reason.startswith("thruster ") and " A, over " in outcome.reason
        assert session.sim.thrusters.outputs == [0.0] * session.rig.thrusters.count
        faults = [e for e in store.events(outcome.run_id) if e.kind == "fault"]
        assert "cut-off" in faults[0].message and max(faults[0].data["current_a"]) > 2.0
        # It stopped at the step that went over, not before: command 0.1 (0.35 A) passed.
        steps = [
            e.data for e in store.events(outcome.run_id) if (e.data or {}).get("step") is not None
        ]
        assert any(s["command"] == 0.1 for s in steps)
        assert all(s["current_a"] <= 2.0 for s in steps if "current_a" in s)
