"""What a rig can do, as the test planner sees it: the loads, directions and travel it offers,
and the release amplitudes of the axes it tests by a release from an offset (a pendulum).

Pure data (no rig file, no device): ``api.core.rig_envelope`` fills it from the rig file and
the stored thrust calibration. The planner and the estimator's advice draw every test they
propose from :meth:`RigEnvelope.candidates`, so neither proposes a load the rig cannot give.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, Literal

import numpy as np

from estimation.data.driven_axes import driven_axis

#: A driven axis (its words: ``estimation.data.driven_axes``) or a released one (its words:
#: its ``ReleaseEnvelope``, from the kind's registry entry).
Axis = str
#: Magnitudes offered per direction and drive: a geometric grid from the largest load down.
GRID_POINTS = 8
#: The smallest load offered, as a share of the largest (smaller barely moves a body).
SMALLEST_SHARE = 1 / 16
#: Release amplitudes offered: a geometric grid from the largest the rig allows down to
#: ``RELEASE_SMALLEST_SHARE`` of it (a smaller release decays to the run's stop amplitude
#: within a few swings and barely shows the amplitude-dependent damping).
RELEASE_POINTS = 8
RELEASE_SMALLEST_SHARE = 1 / 8
#: Run lengths offered per driven load, as shares of the travel in its direction: a run
#: stopped short (``max_distance_m``, ``max_angle_rad``) costs less tank time and may teach
#: more per minute than one to the end of travel (the planner judges; ``run_lengths``).
RUN_LENGTH_SHARES = (1.0, 1 / 2, 1 / 4, 1 / 8)


@dataclass(frozen=True)
class AxisEnvelope:
    """One axis's loads and travel. Units: N and m (surge), N·m and rad (yaw).

    ``max_load``: the rig's limit (``max_force_n`` / ``max_torque_nm``); ``thruster_range``:
    the calibrated (min, max) signed load the thrusters deliver (None: no calibration);
    ``travel``/``reverse_travel``: longest forward/reverse motion (``reverse_travel`` None:
    no reverse run possible); ``drum_radius_m``: spin cord drum (a hung weight w adds
    w·r² of inertia), None for surge; ``max_rate``: speed limit (m/s or rad/s)."""

    axis: Axis
    max_load: float
    travel: float
    reverse_travel: float | None
    max_rate: float
    thruster_range: tuple[float, float] | None = None
    drum_radius_m: float | None = None

    @property
    def kind(self) -> str:
        return driven_axis(self.axis).kind

    def room(self, load: float) -> float:
        """The travel a run under ``load`` has: forward, or back from the far end for a
        negative load (the forward travel where the reverse is not set)."""
        return self.travel if load > 0 else (self.reverse_travel or self.travel)

    @property
    def load_field(self) -> str:
        return driven_axis(self.axis).load_field

    @property
    def unit(self) -> str:
        return driven_axis(self.axis).load_unit


@dataclass(frozen=True)
class ReleaseEnvelope:
    """An axis tested by a release at rest from an offset (a pendulum pulled out and let go),
    in its kind's words (its registry entry fills them): ``kind``, ``command`` (``rig
    <command>``, ``POST /api/jobs/<command>``), the request ``field`` holding the release
    amplitude and its ``option``; the amplitudes the rig file allows,
    (``min_amplitude``, ``max_amplitude``] in ``unit`` (rad); a run's longest duration
    (``max_run_s``, s) and the amplitude over a cycle it stops below (``stop_amplitude``)."""

    axis: Axis
    kind: str
    command: str
    field: str
    option: str
    unit: str
    min_amplitude: float
    max_amplitude: float
    max_run_s: float
    stop_amplitude: float
    #: No reverse run: a release is judged by its amplitude alone.
    reverse_travel: None = None

    def __post_init__(self) -> None:
        if not 0 < self.min_amplitude < self.max_amplitude:
            raise ValueError(
                f"min_amplitude: got {self.min_amplitude:g} {self.unit}, allowed: 0 < "
                f"min_amplitude < max_amplitude ({self.max_amplitude:g} {self.unit})"
            )

    def amplitudes(self) -> list[float]:
        """The release amplitudes offered (``RELEASE_POINTS``, geometric, largest last)."""
        low = max(self.min_amplitude, RELEASE_SMALLEST_SHARE * self.max_amplitude)
        return [float(a) for a in np.geomspace(low, self.max_amplitude, RELEASE_POINTS)]


@dataclass(frozen=True)
class Candidate:
    """One test the rig can run: its kind, signed load and drive (weight | thrusters), or
    for a released axis (``release``: its envelope) the release amplitude as ``load``."""

    axis: Axis
    load: float
    drive: Literal["weight", "thrusters", "release"] = "weight"
    release: ReleaseEnvelope | None = None
    #: A driven run stopped after this distance (m) or angle (rad); None: the rig's full
    #: travel in its direction.
    travel: float | None = None

    @property
    def kind(self) -> str:
        return self.release.kind if self.release else driven_axis(self.axis).kind

    @property
    def field(self) -> str:
        return self.release.field if self.release else driven_axis(self.axis).load_field

    @property
    def command(self) -> str:
        """The ``rig`` command that records it."""
        if self.release:
            return f"rig {self.release.command} {self.release.option} {self.load:.4g}"
        return driven_axis(self.axis).command_line(self.load, self.drive, self.travel)

    def request(self) -> dict[str, Any]:
        """The body of ``POST /api/jobs/<route>``."""
        if self.release:
            return {self.release.field: float(f"{self.load:.4g}")}
        return driven_axis(self.axis).request(self.load, self.drive, self.travel)

    def describe(self) -> str:
        if self.release:
            degrees = f" ({np.degrees(self.load):.3g}°)" if self.release.unit == "rad" else ""
            return f"{self.kind} released from {self.load:.4g} {self.release.unit}{degrees}"
        words = driven_axis(self.axis)
        way = "reverse " if self.load < 0 else ""
        by = "the thrusters" if self.drive == "thrusters" else "a hung weight"
        short = (
            "" if self.travel is None else f", stopped after {self.travel:.4g} {words.travel_unit}"
        )
        return f"{way}{self.kind} at {self.load:.4g} {words.load_unit} driven by {by}{short}"


@dataclass(frozen=True)
class RigEnvelope:
    """The axes a rig can test, with ``g`` (m/s², hung weight = load/g) and the time between
    runs (``reset_s``: carriage back, water settling), which counts as tank time."""

    axes: tuple[AxisEnvelope | ReleaseEnvelope, ...]
    g: float = 9.81
    reset_s: float = 30.0

    def axis(self, axis: str) -> AxisEnvelope | ReleaseEnvelope | None:
        return next((a for a in self.axes if a.axis == axis), None)

    def driven(self, axis: str) -> AxisEnvelope | None:
        """``axis``'s envelope when a load drives it (None: not tested, or released)."""
        env = self.axis(axis)
        return env if isinstance(env, AxisEnvelope) else None

    def released(self, axis: str) -> ReleaseEnvelope | None:
        """``axis``'s envelope when it is tested by a release (None: not, or driven)."""
        env = self.axis(axis)
        return env if isinstance(env, ReleaseEnvelope) else None

    def candidates(self, axis: str) -> list[Candidate]:
        """Every test offered on ``axis``: weight loads within ±``max_load`` (reverse only if
        the rig can run it), thruster loads within the calibrated range; on a released axis
        its release amplitudes (``ReleaseEnvelope.amplitudes``)."""
        env = self.axis(axis)
        if env is None:
            return []
        if isinstance(env, ReleaseEnvelope):
            return [Candidate(env.axis, a, "release", env) for a in env.amplitudes()]
        out: list[Candidate] = []
        grid = env.max_load * np.geomspace(SMALLEST_SHARE, 1.0, GRID_POINTS)
        signs = (1.0, -1.0) if env.reverse_travel is not None else (1.0,)
        for sign in signs:
            out += [Candidate(env.axis, float(sign * m)) for m in grid]
        if env.thruster_range is not None:
            low, high = env.thruster_range
            for end in (low, high):
                if end == 0 or (end < 0 and env.reverse_travel is None):
                    continue
                reach = min(abs(end), env.max_load)
                out += [
                    Candidate(env.axis, float(np.sign(end) * m), "thrusters")
                    for m in reach * np.geomspace(SMALLEST_SHARE * 2, 1.0, GRID_POINTS // 2)
                ]
        return out

    def run_lengths(self, test: Candidate) -> list[Candidate]:
        """``test`` to the end of travel and stopped short after each ``RUN_LENGTH_SHARES``
        of the travel in its direction (a released axis's test: itself)."""
        env = self.driven(test.axis)
        if env is None or test.release is not None:
            return [test]
        room = env.room(test.load)
        return [test] + [replace(test, travel=share * room) for share in RUN_LENGTH_SHARES[1:]]

    def allows(self, axis: str, load: float, drive: str = "weight") -> bool:
        """Whether the rig can run ``load`` on ``axis`` with ``drive``."""
        env = self.axis(axis)
        if isinstance(env, ReleaseEnvelope):
            return drive == "release" and 0 < load <= env.max_amplitude
        if env is None or load == 0 or abs(load) > env.max_load:
            return False
        if load < 0 and env.reverse_travel is None:
            return False
        if drive == "thrusters":
            if env.thruster_range is None:
                return False
            return env.thruster_range[0] <= load <= env.thruster_range[1]
        return True
