"""What each motion response of a 6-DOF vehicle measures, on which manoeuvre (``RESPONSES``,
keyed by name): final values, 90 % rise times, the path length at a time, the turning
diameter — each with whether the signal had settled (its last 5 % drifting by less than
``SETTLED_DRIFT`` of its value)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from estimation.vehicle.simulation import Trajectory

#: A response counts as settled when its last-5 % drift is below this fraction of its value.
SETTLED_DRIFT = 1e-3


@dataclass(frozen=True)
class Manoeuvre:
    """A constant generalized force (6,) from rest, for ``duration_s`` at step ``dt``."""

    name: str
    force: tuple[float, ...]
    duration_s: float
    dt: float
    description: str

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "force": list(self.force),
            "duration_s": self.duration_s,
            "dt": self.dt,
            "description": self.description,
        }


@dataclass(frozen=True)
class ResponseValue:
    """A measured response; ``settled`` is False when the signal was still drifting."""

    value: float
    settled: bool = True


@dataclass(frozen=True)
class Response:
    """A named response: unit, the manoeuvre it is measured on, how it is measured."""

    name: str
    unit: str
    manoeuvre: str
    description: str
    measure: Callable[[Trajectory, Manoeuvre, Mapping[str, float]], ResponseValue] = field(
        repr=False, compare=False
    )

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "unit": self.unit,
            "manoeuvre": self.manoeuvre,
            "description": self.description,
        }


def _final(signal: np.ndarray, t: np.ndarray) -> ResponseValue:
    """Last value, settled if the last 5 % drift less than SETTLED_DRIFT of it."""
    value = float(signal[-1])
    k = max(1, int(0.95 * len(t)))
    drift = abs(float(signal[-1] - signal[k - 1]))
    return ResponseValue(value, drift <= SETTLED_DRIFT * max(abs(value), 1e-12))


def _rise_time(signal: np.ndarray, t: np.ndarray, fraction: float = 0.9) -> ResponseValue:
    """First time the signal reaches ``fraction`` of its final value (linear interpolation)."""
    end = _final(signal, t)
    target = fraction * end.value
    if end.value == 0:
        return ResponseValue(float("nan"), False)
    s = np.sign(end.value) * signal
    level = abs(target)
    idx = np.flatnonzero(s >= level)
    if idx.size == 0:
        return ResponseValue(float(t[-1]), False)
    k = int(idx[0])
    if k == 0:
        return ResponseValue(float(t[0]), end.settled)
    t0, t1, s0, s1 = t[k - 1], t[k], s[k - 1], s[k]
    return ResponseValue(float(t0 + (level - s0) * (t1 - t0) / (s1 - s0)), end.settled)


def _path_length(traj: Trajectory) -> np.ndarray:
    steps = np.linalg.norm(np.diff(traj.eta[:, :3], axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _steady_surge(traj, man, const) -> ResponseValue:
    return _final(traj.nu[:, 0], traj.t)


def _surge_rise(traj, man, const) -> ResponseValue:
    return _rise_time(traj.nu[:, 0], traj.t)


def _surge_distance(traj, man, const) -> ResponseValue:
    t_d = const["distance_time_s"]
    return ResponseValue(float(np.interp(t_d, traj.t, _path_length(traj))))


def _steady_yaw(traj, man, const) -> ResponseValue:
    return _final(traj.nu[:, 5], traj.t)


def _yaw_rise(traj, man, const) -> ResponseValue:
    return _rise_time(traj.nu[:, 5], traj.t)


def _turn_diameter(traj, man, const) -> ResponseValue:
    speed = np.hypot(traj.nu[:, 0], traj.nu[:, 1])
    r = traj.nu[:, 5]
    if r[-1] == 0:
        return ResponseValue(float("inf"), False)
    u_end, r_end = _final(speed, traj.t), _final(r, traj.t)
    return ResponseValue(2.0 * u_end.value / abs(r_end.value), u_end.settled and r_end.settled)


def _steady_heave(traj, man, const) -> ResponseValue:
    return _final(traj.nu[:, 2], traj.t)


RESPONSES: tuple[Response, ...] = (
    Response(
        "steady_surge_speed",
        "m/s",
        "surge_step",
        "surge speed u at the end of a surge force step from rest",
        _steady_surge,
    ),
    Response(
        "surge_rise_time_90",
        "s",
        "surge_step",
        "time for u to reach 90 % of its final value after a surge force step",
        _surge_rise,
    ),
    Response(
        "distance_at_t",
        "m",
        "surge_step",
        "path length travelled at t = distance_time_s after a surge force step",
        _surge_distance,
    ),
    Response(
        "steady_yaw_rate",
        "rad/s",
        "yaw_step",
        "yaw rate r at the end of a yaw torque step from rest",
        _steady_yaw,
    ),
    Response(
        "yaw_rise_time_90",
        "s",
        "yaw_step",
        "time for r to reach 90 % of its final value after a yaw torque step",
        _yaw_rise,
    ),
    Response(
        "turning_diameter",
        "m",
        "turn",
        "steady turning-circle diameter 2·√(u²+v²)/|r| under combined surge force and yaw "
        "torque (Ds of the turning-circle manoeuvre)",
        _turn_diameter,
    ),
    Response(
        "steady_heave_speed",
        "m/s",
        "heave_step",
        "heave speed w at the end of a heave force step from rest (vehicles with heave thrust)",
        _steady_heave,
    ),
)
RESPONSE_NAMES: tuple[str, ...] = tuple(r.name for r in RESPONSES)
#: The axes each manoeuvre drives.
MANOEUVRE_AXES = {
    "surge_step": ("surge",),
    "yaw_step": ("yaw",),
    "turn": ("surge", "yaw"),
    "heave_step": ("heave",),
}
