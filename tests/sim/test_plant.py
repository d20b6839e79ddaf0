"""Plant physics: seed 000 steady speeds, limits, energy, thrust stand, every effect."""

from __future__ import annotations

import itertools
import math

import pytest

from daq.config import RigConfigError, load_rig
from daq.sim.plant import Plant
from daq.sim.plant_channels import read_channel, write_channel
from daq.sim.scenario import SCENARIO_DIR, Scenario, load_scenario, parse_scenario

RIG = load_rig()
G = RIG.rig.g
SEED_FORCES_N = (4.9, 24.5, 44.1, 83.3)
SEED_MEASURED_M_S = (0.11, 0.27, 0.38, 0.51)


def plant(scenario: Scenario | str | None = None) -> Plant:
    if isinstance(scenario, str):
        scenario = load_scenario(SCENARIO_DIR / f"{scenario}.toml")
    p = Plant(RIG, scenario)
    p.advance(0.0)
    return p


def tow(p: Plant, kg: float, seconds: float, *, every_s: float = 0.1) -> list[tuple[float, float]]:
    """Hang ``kg``, release, and record (t, encoder position) at 10 Hz like the PLC."""
    write_channel(p, "sim_tow_weight", kg)
    write_channel(p, "tow_release", 1)
    out = [(p.sim_time_s, read_channel(p, "tow_position"))]
    for _ in range(round(seconds / every_s)):
        p.advance(every_s)
        out.append((p.sim_time_s, read_channel(p, "tow_position")))
    return out


def speed_at_end(samples: list[tuple[float, float]], window: int = 10) -> float:
    (t0, x0), (t1, x1) = samples[-1 - window], samples[-1]
    return (x1 - x0) / (t1 - t0)


def test_steady_tow_speeds_match_seed_000_within_10_percent():
    rows = []
    for force, measured in zip(SEED_FORCES_N, SEED_MEASURED_M_S, strict=True):
        p = plant()
        samples = tow(p, force / G, seconds=min(16.0, 4.5 / measured))
        simulated = speed_at_end(samples)
        rows.append((force, measured, simulated, p.steady_tow_speed(force)))
    print("\n force N | seed 000 m/s | simulated m/s | closed form m/s | error")
    for force, measured, simulated, closed in rows:
        err = (simulated - measured) / measured
        print(f" {force:7.1f} | {measured:12.3f} | {simulated:13.3f} | {closed:15.3f} | {err:+.1%}")
    for force, measured, simulated, closed in rows:
        assert simulated == pytest.approx(measured, rel=0.10), f"{force} N"
        assert simulated == pytest.approx(closed, rel=0.02), f"{force} N not yet steady"


def test_spin_steady_rate_matches_seed_000_first_torque():
    p = plant()
    write_channel(p, "sim_spin_weight", 0.5)
    write_channel(p, "spin_release", 1)
    p.advance(20.0)
    # 4.12 ω² + 0.119 ω = 0.454 N·m → 0.318 rad/s; the paper's fit says 0.31.
    assert p.yaw_rate_rad_s == pytest.approx(0.31, rel=0.10)
    assert read_channel(p, "yaw_angle") > 4.0


def test_brake_holds_until_release():
    p = plant()
    write_channel(p, "sim_tow_weight", 8.5)
    p.advance(2.0)
    assert p.position_m == 0.0 and read_channel(p, "tow_position") == 0.0
    write_channel(p, "tow_release", 1)
    p.advance(0.5)
    assert p.position_m > 0.01


def test_end_of_travel_stops_the_carriage_and_engages_the_brake():
    p = plant()
    samples = tow(p, 8.5, seconds=16.0)
    eot = RIG.geometry.end_of_travel_m
    assert p.end_of_travel and read_channel(p, "end_of_travel") == 1.0
    assert p.velocity_m_s == 0.0 and p.tow_braked and read_channel(p, "tow_release") == 0.0
    assert eot <= p.position_m < eot + 0.001
    assert samples[-1][1] == samples[-20][1], "carriage moved after the switch tripped"
    write_channel(p, "tow_release", 1)  # refused while the switch is tripped
    p.advance(1.0)
    assert read_channel(p, "tow_release") == 0.0 and p.velocity_m_s == 0.0
    write_channel(p, "sim_reset", 1)
    assert read_channel(p, "tow_position") == 0.0 and not p.end_of_travel and p.tow_braked


def test_cord_runs_out_and_the_vehicle_coasts_down():
    p = plant()
    write_channel(p, "sim_spin_weight", 8.5)
    write_channel(p, "spin_release", 1)
    p.advance(60.0)
    assert p.cord_out
    rate = p.yaw_rate_rad_s
    p.advance(5.0)
    assert 0 <= p.yaw_rate_rad_s < rate


def test_without_drive_a_moving_carriage_only_slows_down():
    p = plant()
    write_channel(p, "tow_release", 1)
    p.advance(0.01)
    p.velocity_m_s = 0.5
    p.yaw_rate_rad_s = 0.0
    write_channel(p, "spin_release", 1)
    p.yaw_rate_rad_s = 1.0
    speeds, rates = [], []
    for _ in range(200):
        p.advance(0.05)
        speeds.append(p.velocity_m_s)
        rates.append(p.yaw_rate_rad_s)
    assert all(b <= a for a, b in itertools.pairwise(speeds))
    assert all(b <= a for a, b in itertools.pairwise(rates))
    assert 0 <= speeds[-1] < 0.05 and 0 <= rates[-1] < 0.2


def test_kinetic_energy_never_exceeds_the_work_of_the_weight():
    p = plant()
    kg = 4.5
    mass = 143.26 + kg + RIG.geometry.pulley_inertia_kg_m2 / RIG.geometry.pulley_radius_m**2
    write_channel(p, "sim_tow_weight", kg)
    write_channel(p, "tow_release", 1)
    for _ in range(50):
        p.advance(0.1)
        kinetic = 0.5 * mass * p.velocity_m_s**2
        assert kinetic <= kg * G * p.position_m + 1e-9


def test_polling_does_not_change_the_physics():
    one, many = plant(), plant()
    for p in (one, many):
        write_channel(p, "sim_tow_weight", 2.5)
        write_channel(p, "tow_release", 1)
    one.advance(3.0)
    for _ in range(300):
        many.advance(0.01)
    assert one.steps == many.steps
    assert one.position_m == many.position_m and one.velocity_m_s == many.velocity_m_s


def test_the_plant_clock_keeps_the_host_time_it_is_advanced_to():
    """A clock tick at a whole number of ms (12.3 s after the start) finds the plant there,
    not a step behind: 12.3 / 0.001 is 12299.999… in floating point. A step behind, the PLC
    clock read 1 ms early and a release written then let the brake go 1 ms early, which a
    campaign on the clean scenario fitted as a release delay of −1.1 ms."""
    p = Plant(RIG)
    p.advance_to(1000.0)
    for k in range(1, 300):
        ms = 100 * k + 7 * (k % 3)  # 10 Hz ticks and whole-ms instants between them
        p.advance_to(1000.0 + ms / 1000)
        assert p.steps == ms


def test_encoder_resolution_quantizes_position():
    p = plant(parse_scenario({"sensors": {"encoder_counts_per_m": 1000}}))
    tow(p, 2.5, seconds=1.0)
    x = read_channel(p, "tow_position")
    assert x == pytest.approx(round(x * 1000) / 1000, abs=1e-12)
    assert abs(x - p.position_m) <= 0.0005 + 1e-12


# ---- thrust stand -------------------------------------------------------------------------
def stand_reading(p: Plant, commands: list[float], seconds: float = 1.5, n: int = 40) -> float:
    write_channel(p, "sim_thrust_stand", 1)
    p.set_commands(commands)
    p.advance(seconds)
    offset = p.scenario.sensors.load_cell_offset_n
    return sum(read_channel(p, "load_cell") for _ in range(n)) / n - offset


def test_thrust_stand_dead_band_asymmetry_concavity_and_lag():
    p = plant()
    assert abs(stand_reading(p, [0.04, 0.04])) < 0.05, "dead band"
    forward = stand_reading(p, [0.6, 0.0])
    reverse = stand_reading(p, [-0.6, 0.0])
    assert -reverse / forward == pytest.approx(0.78, abs=0.02)
    low, mid, high = (stand_reading(p, [u, 0.0]) for u in (0.3, 0.6, 0.9))
    assert mid > (low + high) / 2 + 0.5, "curve is concave"
    assert mid != pytest.approx(low * 4, rel=0.2), "not a square law"
    assert p.position_m == 0.0 and p.yaw_rad == 0.0, "the vehicle stays on the stand"
    # first-order lag: ~63 % of a step after one time constant
    stand_reading(p, [0.0, 0.0])
    tau = p.scenario.thrusters.time_constant_s
    p.set_commands([0.8, 0.0])
    p.advance(tau)
    final = p.static_thrust_n(0.8, p.loaded_voltage_v())
    assert p.thrusts_n[0] / final == pytest.approx(1 - math.exp(-1), abs=0.03)


def test_thrust_falls_with_supply_voltage():
    full = stand_reading(plant(), [0.7, 0.7])
    sagging = plant(parse_scenario({"sensors": {"supply_voltage_v": 13.0}}))
    low = stand_reading(sagging, [0.7, 0.7])
    assert low < 0.8 * full
    assert read_channel(sagging, "supply_voltage") < 13.0


def test_thrusters_drive_the_free_vehicle():
    p = plant()
    write_channel(p, "tow_release", 1)
    write_channel(p, "spin_release", 1)
    p.set_commands([0.5, 0.5])
    p.advance(3.0)
    assert p.velocity_m_s > 0.1 and abs(p.yaw_rate_rad_s) < 1e-9
    write_channel(p, "sim_reset", 1)
    write_channel(p, "spin_release", 1)
    p.set_commands([0.5, -0.5])
    p.advance(3.0)
    assert p.yaw_rate_rad_s > 0.05 and p.position_m == 0.0
    telemetry = p.telemetry()
    assert telemetry[0][0] > 0 > telemetry[1][0] and telemetry[0][1] > 0


# ---- scenario effects, each against the clean plant -----------------------------------------
def tow_speed(scenario: str, kg: float, seconds: float = 8.0) -> float:
    return speed_at_end(tow(plant(scenario), kg, seconds))


def test_coulomb_friction_slows_the_tow_and_holds_a_light_weight():
    assert tow_speed("coulomb-friction", 2.5) < tow_speed("clean", 2.5) - 0.01
    stuck = plant("coulomb-friction")
    tow(stuck, 0.3, seconds=3.0)  # 2.9 N is below the 4 N break-away
    assert stuck.position_m == 0.0


def test_bias_current_pushes_even_without_a_weight():
    assert tow_speed("bias-current", 2.5) > tow_speed("clean", 2.5) + 0.005
    p = plant("bias-current")
    tow(p, 0.0, seconds=3.0)
    assert p.position_m > 0.01


def test_tether_torsion_holds_back_the_spin():
    def angle(name: str) -> float:
        p = plant(name)
        write_channel(p, "sim_spin_weight", 0.5)
        write_channel(p, "spin_release", 1)
        p.advance(20.0)
        return p.yaw_rad

    assert angle("tether-torsion") < angle("clean") - 0.3


def test_elastic_rope_makes_the_carriage_surge():
    def speed_reversals(name: str) -> int:
        p = plant(name)
        write_channel(p, "sim_tow_weight", 2.5)
        write_channel(p, "tow_release", 1)
        speeds = []
        for _ in range(200):
            p.advance(0.02)
            speeds.append(p.velocity_m_s)
        accel = [b - a for a, b in itertools.pairwise(speeds)]
        return sum(1 for a, b in itertools.pairwise(accel) if a > 0 >= b)

    assert speed_reversals("rope-elastic") >= 3  # the carriage surges to and fro
    assert speed_reversals("clean") == 0  # a rigid rope gives a smooth first-order rise


def test_cubic_drag_bites_hardest_at_high_speed():
    slow = tow_speed("cubic-drag", 0.5, 14.0) / tow_speed("clean", 0.5, 14.0)
    fast = tow_speed("cubic-drag", 8.5, 8.0) / tow_speed("clean", 8.5, 8.0)
    assert fast < slow < 1.0
    assert fast < 0.97


def test_release_delay_holds_the_carriage_after_the_release_command():
    samples = tow(plant("release-delay"), 8.5, seconds=1.0, every_s=0.05)
    still = [x for t, x in samples if t < 0.3]
    assert still and all(x == 0.0 for x in still)
    assert samples[-1][1] > 0.01


# ---- scenario file ---------------------------------------------------------------------------
def test_every_scenario_fixture_loads():
    names = {p.stem for p in SCENARIO_DIR.glob("*.toml")}
    assert {"clean", "coulomb-friction", "bias-current", "tether-torsion"} <= names
    for path in SCENARIO_DIR.glob("*.toml"):
        assert load_scenario(path).name == path.stem


def test_bad_scenario_names_field_value_and_range(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        "[effects]\ncoulomb_friction_n = -2\nwind = 1\n[sensors]\nload_cell_noise_n = 99\n"
    )
    with pytest.raises(RigConfigError) as err:
        load_scenario(bad)
    text = str(err.value)
    assert "effects.coulomb_friction_n: Input should be greater than or equal to 0 (got -2)" in text
    assert "effects.wind" in text and "sensors.load_cell_noise_n" in text and "(got 99)" in text


@pytest.mark.parametrize(
    ("scenario", "direction"),
    [
        ("coulomb-friction", -1),  # bearing friction slows the spin
        ("bias-current", +1),  # the current's torque adds to the drum torque
        ("tether-torsion", -1),
        ("cubic-drag", -1),
        ("release-delay", -1),  # starts late
    ],
)
def test_each_effect_moves_the_spin_test_the_expected_way(scenario, direction):
    def angle_after(name: str) -> float:
        p = plant(name)
        write_channel(p, "sim_spin_weight", 1.0)
        write_channel(p, "spin_release", 1)
        p.advance(12.0)
        return read_channel(p, "yaw_angle")

    change = angle_after(scenario) - angle_after("clean")
    assert change * direction > 0.05, f"{scenario}: yaw angle changed by {change:+.3f} rad"


@pytest.mark.parametrize("scenario", ["clean", "rope-elastic", "bias-current"])
def test_a_weight_over_the_far_end_pulley_mirrors_the_tow(scenario):
    """Rigged the other way (``sim_tow_reversed``), the same weight pulls the carriage from
    the far end back toward the start at the speed the forward tow reaches; a current (which
    does not flip) helps one way and hinders the other by the same force."""

    def travel(reverse: bool) -> tuple[float, float]:
        p = plant(scenario)
        start = RIG.geometry.reverse_start if reverse else 0.0
        write_channel(p, "sim_carriage_position", start)
        assert p.position_m == start and read_channel(p, "sim_tow_reversed") == 0
        write_channel(p, "sim_tow_weight", 2.5)
        write_channel(p, "sim_tow_reversed", 1 if reverse else 0)
        write_channel(p, "tow_release", 1)
        p.advance(8.0)
        return p.position_m - start, p.velocity_m_s

    (fwd_x, fwd_v), (back_x, back_v) = travel(False), travel(True)
    assert back_x < -0.5 and back_v < 0
    p = plant(scenario)  # the closed form adds the scenario's bias to the force it is given
    assert fwd_v == pytest.approx(p.steady_tow_speed(2.5 * G), rel=0.02)
    assert back_v == pytest.approx(p.steady_tow_speed(-2.5 * G), rel=0.02)
    if scenario == "bias-current":
        assert -back_v < fwd_v - 0.01  # the current hinders the reverse tow
    if scenario != "bias-current":
        assert back_x == pytest.approx(-fwd_x, rel=1e-6)  # an exact mirror


def test_a_cord_wound_the_other_way_turns_the_vehicle_negative_until_it_runs_out():
    p = plant()
    write_channel(p, "sim_spin_weight", 2.5)
    write_channel(p, "sim_spin_reversed", 1)
    write_channel(p, "spin_release", 1)
    p.advance(3.0)
    assert p.yaw_rad < -1.0 and p.yaw_rate_rad_s < 0 and not p.cord_out
    write_channel(p, "sim_reset", 1)  # returning the vehicle rigs the cord the normal way again
    assert read_channel(p, "sim_spin_reversed") == 0 and read_channel(p, "sim_tow_reversed") == 0


def test_the_carriage_cannot_be_pushed_past_the_switch():
    with pytest.raises(ValueError, match=r"sim_carriage_position: 5\.5 m is not allowed"):
        write_channel(plant(), "sim_carriage_position", RIG.geometry.end_of_travel_m)
