"""The simulated pendulum: period, envelope, dry friction, energy, latch over Modbus."""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from daq.config import RigConfig, RigConfigError, load_rig, parse_rig
from daq.registers import encode
from daq.sim.plant import Plant
from daq.sim.plant_channels import read_channel, write_channel
from daq.sim.plc_server import SimulatedPLC
from daq.sim.scenario import Scenario, parse_scenario
from tests.sim.test_plc import UNIT, read_si, tcp_client
from tests.support.waiting import until

RIG = load_rig()
LINEAR_ONLY = parse_scenario({"surge": {"quadratic_damping": 0.0}})


def with_pendulum(rig: RigConfig, **changes: float) -> RigConfig:
    assert rig.pendulum is not None
    return rig.model_copy(update={"pendulum": rig.pendulum.model_copy(update=changes)})


def formula(rig: RigConfig, scenario: Scenario) -> tuple[float, float, float]:
    """(J_total, k, linear damping) straight from seed 002 eq. 169 and the rig file."""
    p, m_z, g = rig.pendulum, rig.vehicle.dry_mass_kg, rig.rig.g
    arm, surge = p.pivot_to_vehicle_m, scenario.surge
    alpha = surge.inertia_kg - m_z
    j_total = p.rod_inertia_kg_m2 + m_z * arm**2 + p.vehicle_inertia_kg_m2 + alpha * arm**2
    k = ((m_z - p.buoyancy_kg) * arm + p.rod_mass_kg * p.rod_cg_m) * g
    return j_total, k, surge.linear_damping * arm**2 + p.pivot_damping_nm_s


def swing(plant: Plant, start_rad: float, seconds: float, every_s: float = 0.01) -> np.ndarray:
    """Pull out, release, and return rows (t, angle, energy) every ``every_s``."""
    plant.advance(0.0)
    write_channel(plant, "sim_pendulum_angle", start_rad)
    write_channel(plant, "pendulum_release", 1)
    rows = []
    for _ in range(round(seconds / every_s)):
        plant.advance(every_s)
        rows.append((plant.sim_time_s, plant.pendulum.angle_rad, plant.pendulum.energy_j()))
    return np.array(rows)


def up_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


def peaks(x: np.ndarray) -> np.ndarray:
    """|angle| at every turning point (both sides)."""
    i = np.flatnonzero((np.abs(x[1:-1]) >= np.abs(x[:-2])) & (np.abs(x[1:-1]) > np.abs(x[2:])))
    return np.abs(x[1:-1][i])


def test_small_angle_period_and_envelope_match_the_formula():
    plant = Plant(RIG, LINEAR_ONLY)
    rows = swing(plant, 0.02, 60.0)
    t, x = rows[:, 0], rows[:, 1]
    j_total, k, c = formula(RIG, LINEAR_ONLY)
    decay = c / (2 * j_total)
    period = 2 * math.pi / math.sqrt(k / j_total - decay**2)
    assert 10 < period < 20  # BENBAM on the seed 002 rod: a slow swing
    assert np.mean(np.diff(up_crossings(t, x))) == pytest.approx(period, rel=2e-3)
    # The envelope: ln|peak| falls linearly with slope −K.
    i = np.flatnonzero((np.abs(x[1:-1]) >= np.abs(x[:-2])) & (np.abs(x[1:-1]) > np.abs(x[2:]))) + 1
    slope = np.polyfit(t[i], np.log(np.abs(x[i])), 1)[0]
    assert -slope == pytest.approx(decay, rel=0.01)


def test_dry_pivot_friction_takes_a_constant_amount_off_every_cycle():
    # No viscous damping at all: only the pivot's Coulomb friction takes energy out.
    rig = with_pendulum(RIG, pivot_damping_nm_s=0.0, buoyancy_kg=20.0)
    scenario = parse_scenario(
        {
            "surge": {"linear_damping": 0.0, "quadratic_damping": 0.0},
            "effects": {"pivot_coulomb_friction_nm": 0.6},
        }
    )
    plant = Plant(rig, scenario)
    _, k, _ = formula(rig, scenario)
    rows = swing(plant, 0.1, 70.0, every_s=0.002)
    amplitudes = peaks(rows[:, 1])
    per_cycle = amplitudes[:-2] - amplitudes[2:]  # same side, one full cycle apart
    assert len(per_cycle) >= 4
    # The classic result: a linear (not exponential) decay of 4 τ_c / k per cycle.
    assert per_cycle == pytest.approx(np.full_like(per_cycle, 4 * 0.6 / k), rel=0.02)
    # It ends stuck inside the friction band, and the plant then counts as quiescent.
    assert abs(rows[-1, 1]) <= 0.6 / k + 1e-9
    assert plant.pendulum.rate_rad_s == 0.0 and plant.pendulum.quiescent


def test_energy_never_increases():
    scenario = parse_scenario({"effects": {"pivot_coulomb_friction_nm": 0.1}})
    rows = swing(Plant(RIG, scenario), 0.45, 30.0, every_s=0.001)
    energy = rows[:, 2]
    assert energy[-1] < 0.5 * energy[0]
    assert np.all(np.diff(energy) <= 1e-9 * energy[0])


def test_swinging_pendulum_is_integrated_and_a_caught_one_is_quiescent():
    plant = Plant(RIG)
    plant.advance(0.0)
    write_channel(plant, "sim_pendulum_angle", 0.3)
    plant.advance(1.0)
    assert read_channel(plant, "pendulum_angle") == pytest.approx(
        0.3, abs=1e-4
    )  # held by the latch
    assert read_channel(plant, "sim_pendulum_angle") == pytest.approx(0.3)
    write_channel(plant, "pendulum_release", 1)
    plant.advance(2.0)
    swung = read_channel(plant, "pendulum_angle")
    assert swung < 0.29  # released: it swings, nothing skipped the integration
    write_channel(plant, "pendulum_release", 0)
    caught = plant.pendulum.angle_rad
    steps = plant.steps
    plant.advance(1.0)
    assert plant.pendulum.angle_rad == caught and plant.steps == steps + 1000
    assert read_channel(plant, "sim_pendulum_angle") == pytest.approx(caught)  # held where caught
    with pytest.raises(ValueError, match=r"sim_pendulum_angle: must be within ±0\.5 rad"):
        write_channel(plant, "sim_pendulum_angle", 0.8)
    write_channel(plant, "pendulum_release", 1)
    write_channel(plant, "sim_reset", 1)  # everything back to the start: hanging plumb, latched
    assert (
        read_channel(plant, "pendulum_angle") == 0.0
        and read_channel(plant, "pendulum_release") == 0.0
    )


def test_encoder_resolution_and_noise_come_from_the_scenario():
    plant = Plant(RIG, parse_scenario({"sensors": {"pendulum_counts_per_rad": 100}}))
    write_channel(plant, "sim_pendulum_angle", 0.1234)
    assert read_channel(plant, "pendulum_angle") == pytest.approx(0.12)
    noisy = Plant(RIG, parse_scenario({"sensors": {"pendulum_angle_noise_rad": 0.01}}))
    write_channel(noisy, "sim_pendulum_angle", 0.1)
    readings = [read_channel(noisy, "pendulum_angle") for _ in range(400)]
    assert np.std(readings) == pytest.approx(0.01, rel=0.2)


def test_rig_file_pendulum_section_is_checked():
    data = load_rig().model_dump()
    assert RIG.pendulum is not None and RIG.pendulum.axis == "surge"
    bad = dict(data, pendulum=dict(data["pendulum"], rod_inertia_kg_m2=1.0))
    with pytest.raises(RigConfigError, match="rod_inertia_kg_m2 must be at least"):
        parse_rig(bad)
    floating = dict(data, pendulum=dict(data["pendulum"], buoyancy_kg=40.0))
    with pytest.raises(RigConfigError, match="must be positive"):
        parse_rig(floating)
    no_latch = dict(data, channels=[c for c in data["channels"] if c["name"] != "pendulum_release"])
    with pytest.raises(RigConfigError, match=r"needs channel.*pendulum_release"):
        parse_rig(no_latch)
    # A rig without a pendulum still loads, and its plant has none.
    plain = parse_rig({k: v for k, v in data.items() if k != "pendulum"})
    assert plain.pendulum is None and Plant(plain).pendulum is None
    sway = with_pendulum(RIG, axis="sway")
    with pytest.raises(ValueError, match=r"give a \[sway\] section"):
        Plant(sway)


async def test_release_and_catch_over_modbus():
    plc = SimulatedPLC(RIG, Plant(RIG))
    client = await tcp_client(await plc.start_tcp())
    try:
        hold = RIG.channel("sim_pendulum_angle")
        release = RIG.channel("pendulum_release").address
        rr = await client.write_registers(hold.address, encode(hold, 0.25), device_id=UNIT)
        assert not rr.isError()

        async def angle_near(target: float) -> bool:
            return await read_si(client, "pendulum_angle") == pytest.approx(target, abs=1e-4)

        await until(lambda: angle_near(0.25), "the pendulum held at 0.25 rad", timeout_s=5)
        assert not (await client.write_coil(release, True, device_id=UNIT)).isError()
        assert await read_si(client, "pendulum_release") == 1.0

        async def swinging() -> bool:
            return await read_si(client, "pendulum_angle") < 0.245

        await until(swinging, "the pendulum swinging off 0.25 rad", timeout_s=5)
        assert not (await client.write_coil(release, False, device_id=UNIT)).isError()
        caught = await read_si(client, "pendulum_angle")
        await asyncio.sleep(0.3)  # observation window: a caught pendulum stays where it is
        assert await read_si(client, "pendulum_angle") == pytest.approx(caught, abs=2e-5)
        # Beyond max_angle_rad the PLC refuses the write.
        rr = await client.write_registers(hold.address, encode(hold, 0.9), device_id=UNIT)
        assert rr.isError() and rr.exception_code == 3  # ILLEGAL_VALUE
    finally:
        client.close()
        await plc.stop()
