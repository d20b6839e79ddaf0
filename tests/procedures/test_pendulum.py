"""Pendulum free decay end to end: simulated rig → Modbus → clock → store → estimator view."""

from __future__ import annotations

import asyncio
import json
import math
from pathlib import Path

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE, RigConfig
from daq.procedures.axis_steps import PreconditionFailed
from daq.procedures.params import ParameterError
from daq.procedures.pendulum import CycleAmplitude, run_pendulum_decay
from daq.procedures.recording import AbortSignal
from daq.procedures.requests import pendulum_parameters
from daq.procedures.sequence import parse_sequence
from daq.run_data import load_pendulum_data
from daq.session import RigSource
from daq.sim.scenario import Scenario
from daq.store import Store
from tests.procedures.test_cli import rig
from tests.store.helpers import new_run
from tests.support.progress_log import ProgressLog
from tests.support.simrig import rig_session
from tests.support.waiting import next_samples

pytestmark = pytest.mark.simtime

#: A short, bottom-heavy pendulum (period ≈ 3.6 s) so a decay fits in a fast test.
FAST_PENDULUM = """
[pendulum]
pivot_to_vehicle_m = 0.5
rod_mass_kg = 7.88
rod_cg_m = 0.25
rod_inertia_kg_m2 = 0.6
vehicle_inertia_kg_m2 = 1.1
buoyancy_kg = 10.0
pivot_damping_nm_s = 0.228
max_angle_rad = 0.5
axis = "surge"
"""


def fast_rig_file(tmp_path: Path) -> Path:
    """BENBAM's rig file with the fast pendulum in place of the seed 002 one."""
    text = DEFAULT_RIG_FILE.read_text(encoding="utf-8")
    path = tmp_path / "fast-pendulum.toml"
    path.write_text(text[: text.index("[pendulum]")] + FAST_PENDULUM, encoding="utf-8")
    return path


def linear_period(rig: RigConfig, scenario: Scenario) -> float:
    """Damped period of the linearised swing, from seed 002 eq. 171 and the rig file."""
    p, m_z = rig.pendulum, rig.vehicle.dry_mass_kg
    arm = p.pivot_to_vehicle_m
    alpha = scenario.surge.inertia_kg - m_z
    j_total = p.rod_inertia_kg_m2 + m_z * arm**2 + p.vehicle_inertia_kg_m2 + alpha * arm**2
    k = ((m_z - p.buoyancy_kg) * arm + p.rod_mass_kg * p.rod_cg_m) * rig.rig.g
    decay = (scenario.surge.linear_damping * arm**2 + p.pivot_damping_nm_s) / (2 * j_total)
    return 2 * math.pi / math.sqrt(k / j_total - decay**2)


@pytest.fixture
async def fast_session(tmp_path, store):
    source = RigSource.load(fast_rig_file(tmp_path))
    async with rig_session(source, store) as s:
        yield s


async def test_free_decay_is_recorded_released_caught_and_loads_for_the_estimator(
    fast_session, store
):
    session = fast_session
    params = pendulum_parameters(
        {"start_angle_rad": 0.3, "stop_amplitude_rad": 0.09, "max_time_s": 20, "baseline_s": 0.5},
        session.rig,
    )
    progress = []
    outcome = await run_pendulum_decay(session, params, progress=progress.append)

    assert outcome.status == "completed" and outcome.kind == "pendulum"
    run = store.get_run(outcome.run_id)
    assert run.kind == "pendulum" and run.parameters["start_angle_rad"] == 0.3
    events = store.events(outcome.run_id)
    actions = [e.data.get("action") for e in events if e.data]
    assert actions.index("release") < actions.index("catch")
    release = next(e for e in events if e.data and e.data.get("action") == "release")
    assert release.data["t_half_width"] >= 0 and release.data["t_mono"] > 0
    catch = next(e for e in events if e.data and e.data.get("action") == "catch")
    assert catch.message.startswith("amplitude")  # it decayed before max_time_s
    assert await session.plc.read("pendulum_release") == 0
    assert progress[-1].fraction == 1.0 and progress[-1].state == "completed"

    # The estimator's view: geometry from the stored rig file, samples up to the catch.
    data = load_pendulum_data(store, outcome.run_id)
    geo = data.geometry
    assert (geo.pivot_to_vehicle_m, geo.rod_cg_m, geo.buoyancy_kg) == (0.5, 0.25, 10.0)
    assert geo.vehicle_mass_kg == 30.0 and geo.g == session.rig.rig.g
    assert data.axis == "surge" and data.t[0] < data.t_release < data.t[-1]
    assert 0 < data.t_release_std < 0.05
    held = data.angle[data.t < data.t_release - 0.1]
    assert held == pytest.approx(np.full_like(held, 0.3), abs=1e-4)  # latched at the start
    t, angle = data.decay()
    assert np.all(np.diff(t) > 0)
    # The recorded period matches the plant's formula (10 Hz samples, interpolated crossings).
    up = np.flatnonzero((angle[:-1] < 0) & (angle[1:] >= 0))
    crossings = t[up] - angle[up] * (t[up + 1] - t[up]) / (angle[up + 1] - angle[up])
    assert len(crossings) >= 2
    expected = linear_period(session.rig, Scenario())
    assert np.mean(np.diff(crossings)) == pytest.approx(expected, rel=0.015)
    # The last swing before the catch is below the stop amplitude; nothing after it is kept.
    last_cycle = angle[t >= t[-1] - expected]
    assert (last_cycle.max() - last_cycle.min()) / 2 < 0.09
    assert len(t) < store.sample_count(outcome.run_id)


async def test_abort_mid_swing_ends_aborted_keeps_samples_and_catches(fast_session, store):
    session = fast_session
    abort = AbortSignal()
    params = pendulum_parameters({"start_angle_rad": 0.2, "baseline_s": 0.3}, session.rig)
    progress = ProgressLog()
    task = asyncio.create_task(run_pendulum_decay(session, params, abort=abort, progress=progress))
    swinging = lambda p: p.message.startswith("pendulum:")  # noqa: E731
    await progress.wait(swinging, "10 samples swinging", times=10, task=task)
    abort.set("operator abort (test)")
    outcome = await asyncio.wait_for(task, 5)
    assert outcome.status == "aborted" and outcome.reason == "operator abort (test)"
    assert store.get_run(outcome.run_id).status == "aborted"
    assert store.sample_count(outcome.run_id) >= 10
    assert await session.plc.read("pendulum_release") == 0  # caught, not left swinging
    ticks = await next_samples(session.acquisition, round(0.3 * session.acquisition.rate_hz) + 1)
    held = [s.channels["pendulum_angle"] for s in ticks]  # 0.3 s of clock ticks
    assert held == pytest.approx([held[0]] * len(held), abs=1e-4)


def test_parameters_are_checked_against_the_pendulum_section(source):
    rig = source.rig
    ok = pendulum_parameters({"start_angle_rad": 0.3}, rig)
    assert (ok.max_time_s, ok.stop_amplitude_rad, ok.baseline_s) == (120.0, 0.005, 1.0)
    with pytest.raises(ParameterError, match=r"start_angle_rad: 0\.7 is not allowed .*max_angle"):
        pendulum_parameters({"start_angle_rad": 0.7}, rig)
    with pytest.raises(ParameterError, match="start_angle_rad: missing"):
        pendulum_parameters({}, rig)
    with pytest.raises(ParameterError, match=r"stop_amplitude_rad: 0\.3 is not allowed"):
        pendulum_parameters({"start_angle_rad": 0.3, "stop_amplitude_rad": 0.3}, rig)
    with pytest.raises(ParameterError, match=r"max_time_s: 1000\.0 is not allowed"):
        pendulum_parameters({"start_angle_rad": 0.3, "max_time_s": 1000}, rig)
    plain = rig.model_copy(update={"pendulum": None})
    with pytest.raises(ParameterError, match=r"rig: .* \(a rig file with a \[pendulum\] section"):
        pendulum_parameters({"start_angle_rad": 0.3}, plain)


def test_load_pendulum_data_refuses_other_runs(store):
    run_id = new_run(store)  # a tow
    with pytest.raises(ValueError, match="kind 'tow' is not a pendulum free-decay run"):
        load_pendulum_data(store, run_id)


def test_cycle_amplitude_follows_a_decaying_and_a_stuck_swing():
    cycle = CycleAmplitude()
    t = np.arange(0, 20, 0.1)
    x = 0.2 * np.exp(-0.1 * t) * np.cos(2 * np.pi * t / 2.5)
    amplitudes = [cycle.add(ti, xi) for ti, xi in zip(t, x, strict=True)]
    assert cycle.period_s == pytest.approx(2.5, rel=0.01)
    assert amplitudes[-1] == pytest.approx(0.2 * np.exp(-0.1 * (20 - 2.5)), rel=0.1)
    # Stuck off-centre by dry friction: no more crossings, the amplitude still reads ~0.
    for ti in np.arange(20, 25, 0.1):
        last = cycle.add(ti, 0.003)
    assert last == pytest.approx(0.0, abs=1e-9)


def test_a_sequence_can_hold_pendulum_steps(source):
    seq = parse_sequence(
        {"steps": [{"kind": "pendulum", "start_angle_rad": 0.2}, {"kind": "tow", "force_n": 4.9}]},
        source.rig,
    )
    assert seq.steps[0].kind == "pendulum" and seq.steps[0].start_angle_rad == 0.2
    with pytest.raises(ParameterError, match=r"steps\[0\]\.start_angle_rad: 0\.9"):
        parse_sequence({"steps": [{"kind": "pendulum", "start_angle_rad": 0.9}]}, source.rig)


@pytest.mark.slow  # `rig` subprocesses on the real stack: the slow lane
def test_cli_runs_a_decay_and_refuses_bad_input(tmp_path):
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    bad = rig("pendulum", "--angle", "0.9", db=db, refused=True)  # while parsing: in process
    assert bad.returncode == 2 and "--angle: 0.9 is not allowed" in bad.stderr
    rig_file = str(fast_rig_file(tmp_path))
    done = rig(
        "pendulum",
        *("--angle", "0.3", "--stop-amplitude", "0.12", "--max-time", "15"),
        *("--baseline", "0.3", "--rig", rig_file, "--json"),
        db=db,
    )
    assert done.returncode == 0, done.stderr
    outcome = json.loads(done.stdout)
    assert outcome["kind"] == "pendulum" and outcome["status"] == "completed"
    with Store(db) as store:
        assert load_pendulum_data(store, outcome["run_id"]).geometry.pivot_to_vehicle_m == 0.5


async def test_a_pendulum_held_off_the_start_angle_is_refused_and_nothing_recorded(tmp_path, store):
    class SloppyOperator:
        """Pulls the pendulum only half way out."""

        def __init__(self) -> None:
            self.plc = None

        async def perform(self, act) -> None:
            if act.name == "pull_pendulum":
                await self.plc.write("sim_pendulum_angle", act.value / 2)
            elif act.name == "mount_pendulum":
                await self.plc.write("sim_pendulum_angle", 0.0)

    operator = SloppyOperator()
    source = RigSource.load(fast_rig_file(tmp_path))
    async with rig_session(source, store, operator=operator) as session:
        operator.plc = session.plc
        params = pendulum_parameters({"start_angle_rad": 0.3}, session.rig)
        with pytest.raises(PreconditionFailed, match=r"held at 0\.150 rad, asked for 0\.300"):
            await run_pendulum_decay(session, params)
        assert session.lock_holder is None
    assert store.list_runs() == []
