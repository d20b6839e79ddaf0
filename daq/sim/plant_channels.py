"""The simulated rig's channels as the PLC serves them: each standard channel's reading of
the plant's state (SI, at the encoder's resolution, with the scenario's sensor noise) and
what a write to it does (releases with the scenario's delay, weights, the simulation's own
switches)."""

from __future__ import annotations

import math
from collections.abc import Callable

from daq.sim.plant import Plant

#: The PLC's heartbeat counter counts up once per this many seconds of simulated time.
HEARTBEAT_PERIOD_S = 0.01


def _tow_position(plant: Plant) -> float:
    counts_per_m = plant.scenario.sensors.encoder_counts_per_m
    return round(plant.position_m * counts_per_m) / counts_per_m


def _yaw_angle(plant: Plant) -> float:
    cpr = plant.scenario.sensors.encoder_counts_per_rad
    return round(plant.yaw_rad * cpr) / cpr


def _load_cell(plant: Plant) -> float:
    sens = plant.scenario.sensors
    force = sum(plant.thrusts_n) if plant.thrust_stand else 0.0
    noise = plant.sensor_noise.gauss(0.0, sens.load_cell_noise_n)
    return force + sens.load_cell_offset_n + noise


def _supply_voltage(plant: Plant) -> float:
    noise = plant.sensor_noise.gauss(0.0, plant.scenario.sensors.supply_voltage_noise_v)
    return plant.loaded_voltage_v() + noise


def _bit(flag: Callable[[Plant], bool]) -> Callable[[Plant], float]:
    return lambda plant: 1.0 if flag(plant) else 0.0


#: Each standard channel's reading of the plant (one look-up per channel a poll reads).
_READINGS: dict[str, Callable[[Plant], float]] = {
    "tow_position": _tow_position,
    "yaw_angle": _yaw_angle,
    "load_cell": _load_cell,
    "supply_voltage": _supply_voltage,
    "heartbeat": lambda plant: float(int(plant.sim_time_s / HEARTBEAT_PERIOD_S + 1e-9)),
    "plc_clock": lambda plant: plant.sim_time_s,
    "tow_release": _bit(lambda plant: plant.tow_release),
    "spin_release": _bit(lambda plant: plant.spin_release),
    "end_of_travel": _bit(lambda plant: plant.end_of_travel),
    "estop": _bit(lambda plant: plant.estop),
    "sim_thrust_stand": _bit(lambda plant: plant.thrust_stand),
    "sim_reset": lambda plant: 0.0,
    "sim_tow_reversed": _bit(lambda plant: plant.tow_reversed),
    "sim_spin_reversed": _bit(lambda plant: plant.spin_reversed),
    "sim_tow_weight": lambda plant: plant.tow_weight_kg,
    "sim_spin_weight": lambda plant: plant.spin_weight_kg,
    "sim_carriage_position": lambda plant: plant.position_m,
}


def read_channel(plant: Plant, name: str) -> float | None:
    """SI value of a standard channel, as the PLC would report it now (None: unknown)."""
    reading = _READINGS.get(name)
    if reading is not None:
        return reading(plant)
    if plant.pendulum is not None:
        return plant.pendulum.read(name)
    return None


def write_channel(plant: Plant, name: str, value: float) -> bool:
    """Apply a write to a standard channel; False if the plant does not know it."""
    on = bool(value)
    t = plant.sim_time_s
    delay = plant.scenario.effects.release_delay_s
    if name == "tow_release":
        if on and not (plant.estop or plant.end_of_travel):
            if not plant.tow_release:
                plant.tow_release = True
                plant.tow_release_at = t + delay
        elif not on:
            plant.engage_tow_brake()
    elif name == "spin_release":
        if on and not plant.estop:
            if not plant.spin_release:
                plant.spin_release = True
                plant.spin_release_at = t + delay
        elif not on:
            plant.engage_spin_brake()
    elif name == "sim_tow_weight":
        _check_weight(name, value)
        plant.tow_weight_kg = float(value)
        if plant.tow_braked:
            plant.hang_weight_at_rest()
    elif name == "sim_spin_weight":
        _check_weight(name, value)
        plant.spin_weight_kg = float(value)
    elif name == "sim_thrust_stand":
        plant.thrust_stand = on
    elif name == "sim_reset":
        if on:
            plant.reset()
    elif name == "sim_carriage_position":  # the operator pushes the carriage there
        _check_position(plant, value)
        plant.reset(float(value))
    elif name == "sim_tow_reversed":
        plant.tow_reversed = on
        if plant.tow_braked:
            plant.hang_weight_at_rest()
    elif name == "sim_spin_reversed":
        plant.spin_reversed = on
    elif name == "estop":
        plant.press_estop(on)
    elif plant.pendulum is not None:
        return plant.pendulum.write(name, value, t)
    else:
        return False
    return True


def _check_position(plant: Plant, value: float) -> None:
    end = plant.rig.geometry.end_of_travel_m
    if not (0.0 <= value < end):
        raise ValueError(
            f"sim_carriage_position: {value} m is not allowed; allowed 0 ≤ x < "
            f"end_of_travel_m ({end:g} m)"
        )


def _check_weight(name: str, value: float) -> None:
    if not (0.0 <= value <= 50.0) or math.isnan(value):
        raise ValueError(f"{name}: weight must be within 0…50 kg, got {value}")
