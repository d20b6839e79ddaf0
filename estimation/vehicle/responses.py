"""Motion responses of a 6-DOF vehicle to standard manoeuvres, for the sensitivity analysis.

Each response is one number measured on a 6-DOF simulation (``estimation.vehicle.dynamics``) of a
manoeuvre whose input is a constant generalized force (N, N·m) applied from rest, so it
works for any vehicle. The manoeuvres are fixed from the *reference* vehicle
(:func:`plan`): force, duration and time step stay the same when a coefficient is changed,
so a changed response is caused by the coefficient alone.

Default forces are a fraction (``DEFAULT_FRACTION``) of what the vehicle's thrusters can
reach along the axis (Σ_j |B_ij|·max_command_j, B the allocation matrix). Durations are
``SETTLE_TIME_CONSTANTS`` time constants of the axis, τ = M/(K_L + 2·K_Q·v*) at the steady
speed v* of the 1-DOF model K_L·v + K_Q·v² = F.

The responses themselves (what each one measures on which manoeuvre) are the table
``estimation.vehicle.response_measures.RESPONSES``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from estimation.vehicle.description import DOFS, Vehicle6
from estimation.vehicle.dynamics import allocation_matrix
from estimation.vehicle.response_measures import (
    MANOEUVRE_AXES,
    RESPONSE_NAMES,
    RESPONSES,
    Manoeuvre,
    Response,
    ResponseValue,
)
from estimation.vehicle.simulation import Trajectory, simulate

#: Default manoeuvre force: this fraction of the thrusters' reach along the axis.
DEFAULT_FRACTION = 0.5
#: Manoeuvres last this many time constants of the driven axis (e^-16 ≈ 1e-7: settled).
SETTLE_TIME_CONSTANTS = 16.0
#: Roll/pitch decay may lengthen a manoeuvre up to this many times its own time constant.
MAX_COUPLED_STRETCH = 20.0
#: A reference manoeuvre rolling or pitching beyond this is reported (rad, 10°).
MAX_ATTITUDE_RAD = float(np.radians(10.0))
#: Output samples per manoeuvre (rise times are interpolated between them).
SAMPLES = 1200
#: "Distance at t" is read at this many time constants of the surge step.
DISTANCE_TIME_CONSTANTS = 3.0


class ResponseError(ValueError):
    """A response that cannot be computed for this vehicle; the message says why."""


@dataclass(frozen=True)
class Plan:
    """Manoeuvres and responses fixed from a reference vehicle."""

    manoeuvres: dict[str, Manoeuvre]
    responses: tuple[Response, ...]
    constants: dict[str, float]  # e.g. distance_time_s

    def to_json(self) -> dict:
        return {
            "manoeuvres": [m.to_json() for m in self.manoeuvres.values()],
            "responses": [r.to_json() for r in self.responses],
            "constants": dict(self.constants),
        }


# ---- planning ---------------------------------------------------------------------------------
def thrust_reach(vehicle: Vehicle6) -> dict[str, float]:
    """Largest generalized force per DOF the thrusters can give (N or N·m): Σ_j |B_ij|·u_max_j."""
    if not vehicle.thrusters:
        return dict.fromkeys(DOFS, 0.0)
    b = np.asarray(allocation_matrix(vehicle), dtype=float)
    u_max = np.array([float(th.max_command) for th in vehicle.thrusters])
    reach = np.abs(b) @ u_max
    return {dof: float(x) for dof, x in zip(DOFS, reach, strict=True)}


def time_constant(vehicle: Vehicle6, dof: str, force: float) -> tuple[float, float]:
    """(τ, v*) of one axis under a constant force: v* solves K_L·v + K_Q·v² = |F|,
    τ = M/(K_L + 2·K_Q·v*) with M rigid + added inertia.

    Raises ``ResponseError`` when the axis has no damping (no steady speed).
    """
    i = DOFS.index(dof)
    m = vehicle.total_inertia(dof)
    k_l, k_q = float(vehicle.linear_damping[i]), float(vehicle.quadratic_damping[i])
    f = abs(float(force))
    if k_l <= 0 and k_q <= 0:
        raise ResponseError(
            f"{dof}: linear_damping = {k_l} and quadratic_damping = {k_q}: the axis has no "
            "damping, so a force step has no steady speed; give a damping > 0"
        )
    v = f / k_l if k_q <= 0 else (-k_l + np.sqrt(k_l**2 + 4 * k_q * f)) / (2 * k_q)
    return float(m / (k_l + 2 * k_q * v)), float(v)


def plan(
    vehicle: Vehicle6,
    names: Sequence[str] | None = None,
    *,
    forces: Mapping[str, float] | None = None,
    fraction: float = DEFAULT_FRACTION,
    distance_time_s: float | None = None,
) -> Plan:
    """Manoeuvres for the responses ``names`` (default: every one the vehicle can do).

    ``distance_time_s`` is the t of ``distance_at_t`` (default ``DISTANCE_TIME_CONSTANTS``
    surge time constants; at most the surge step's duration).

    ``forces`` overrides the step size per axis (``{"surge": 20.0, "yaw": 3.0}``, N / N·m);
    otherwise it is ``fraction`` of the thrusters' reach. A response asked for by name on an
    axis without thrust and without a given force is an error naming both.
    """
    if not 0 < fraction <= 1:
        raise ResponseError(f"fraction: {fraction!r} is not allowed; give 0 < fraction ≤ 1")
    forces = dict(forces or {})
    for axis, f in forces.items():
        if axis not in DOFS:
            raise ResponseError(f"forces: axis {axis!r} is not allowed; allowed: {DOFS}")
        if not np.isfinite(f) or f == 0:
            raise ResponseError(f"forces.{axis}: {f!r} is not allowed; give a non-zero force")
    explicit = names is not None
    chosen = list(RESPONSE_NAMES if names is None else names)
    for name in chosen:
        if name not in RESPONSE_NAMES:
            raise ResponseError(
                f"responses: {name!r} is not allowed; allowed: {', '.join(RESPONSE_NAMES)}"
            )
    if not chosen:
        raise ResponseError("responses: give at least one response")
    reach = thrust_reach(vehicle)
    step = {dof: forces.get(dof, fraction * reach[dof]) for dof in DOFS}
    manoeuvres: dict[str, Manoeuvre] = {}
    responses = []
    constants: dict[str, float] = {}
    by_name = {r.name: r for r in RESPONSES}
    for name in chosen:
        resp = by_name[name]
        axes = MANOEUVRE_AXES[resp.manoeuvre]
        missing = [a for a in axes if step[a] == 0]
        if missing:
            if explicit:
                raise ResponseError(
                    f"responses: {name!r} needs a {missing[0]} force, but the vehicle has no "
                    f"thrust along {missing[0]}; give forces.{missing[0]}"
                )
            continue
        if resp.manoeuvre not in manoeuvres:
            manoeuvres[resp.manoeuvre] = _manoeuvre(vehicle, resp.manoeuvre, axes, step)
        responses.append(resp)
    if not responses:
        raise ResponseError(
            f"vehicle {vehicle.name!r}: no response can be computed (no thrust along surge, "
            "yaw or heave); give forces"
        )
    if "surge_step" in manoeuvres:
        tau, _ = time_constant(vehicle, "surge", step["surge"])
        longest = manoeuvres["surge_step"].duration_s
        if distance_time_s is None:
            distance_time_s = DISTANCE_TIME_CONSTANTS * tau
        elif not (np.isfinite(distance_time_s) and 0 < distance_time_s <= longest):
            raise ResponseError(
                f"distance_time_s: {distance_time_s!r} is not allowed; give 0 < t ≤ "
                f"{longest:.4g} s (the surge step's duration)"
            )
        constants["distance_time_s"] = float(distance_time_s)
    return Plan(manoeuvres=manoeuvres, responses=tuple(responses), constants=constants)


def _manoeuvre(
    vehicle: Vehicle6, name: str, axes: Sequence[str], step: Mapping[str, float]
) -> Manoeuvre:
    force = np.zeros(6)
    taus = []
    for axis in axes:
        force[DOFS.index(axis)] = step[axis]
        taus.append(time_constant(vehicle, axis, step[axis])[0])
    slowest = max(taus)
    # With CG/CB offsets, coupling excites roll/pitch; their oscillations decay with 2·I/K_L.
    offset = any(c != 0 for c in (*vehicle.cg_m, *vehicle.cb_m))
    for dof in ("roll", "pitch") if offset else ():
        i = DOFS.index(dof)
        if vehicle.linear_damping[i] > 0:
            envelope = 2 * vehicle.total_inertia(dof) / vehicle.linear_damping[i]
            slowest = max(slowest, min(envelope, MAX_COUPLED_STRETCH * max(taus)))
    duration = SETTLE_TIME_CONSTANTS * slowest
    dt = duration / SAMPLES  # output spacing; the integrator (LSODA) picks its own steps
    parts = ", ".join(
        f"{axis} {step[axis]:.4g} {'N' if DOFS.index(axis) < 3 else 'N·m'}" for axis in axes
    )
    return Manoeuvre(
        name=name,
        force=tuple(float(x) for x in force),
        duration_s=float(duration),
        dt=float(dt),
        description=f"{parts} step from rest for {duration:.3g} s (dt {dt:.3g} s)",
    )


# ---- evaluation -------------------------------------------------------------------------------
def evaluate(
    vehicle: Vehicle6, the_plan: Plan, *, max_evaluations: int | None = None
) -> dict[str, ResponseValue]:
    """Every response of the plan on ``vehicle`` (one simulation per manoeuvre)."""
    return measure(the_plan, simulate_plan(vehicle, the_plan, max_evaluations=max_evaluations))


def simulate_plan(
    vehicle: Vehicle6, the_plan: Plan, *, max_evaluations: int | None = None
) -> dict[str, Trajectory]:
    """One 6-DOF simulation per manoeuvre of the plan (each refused with a ValueError past
    ``max_evaluations`` right-hand-side evaluations, when given)."""
    return {
        name: simulate(
            vehicle,
            m.duration_s,
            force=np.array(m.force),
            dt=m.dt,
            max_evaluations=max_evaluations,
        )
        for name, m in the_plan.manoeuvres.items()
    }


def measure(the_plan: Plan, trajectories: Mapping[str, Trajectory]) -> dict[str, ResponseValue]:
    """The plan's responses measured on its manoeuvres' trajectories."""
    return {
        r.name: r.measure(
            trajectories[r.manoeuvre], the_plan.manoeuvres[r.manoeuvre], the_plan.constants
        )
        for r in the_plan.responses
    }


def attitude_warnings(the_plan: Plan, trajectories: Mapping[str, Trajectory]) -> list[str]:
    """Manoeuvres in which the vehicle rolled or pitched beyond ``MAX_ATTITUDE_RAD``: its
    responses then describe a tumbling vehicle (e.g. no restoring moment against the
    Munk moment), not the manoeuvre's plane."""
    out = []
    for name, traj in trajectories.items():
        for i, dof in ((3, "roll"), (4, "pitch")):
            peak = float(np.max(np.abs(traj.eta[:, i])))
            if peak > MAX_ATTITUDE_RAD:
                out.append(
                    f"{name}: the vehicle's {dof} reached {np.degrees(peak):.0f}° "
                    f"(> {np.degrees(MAX_ATTITUDE_RAD):.0f}°): its responses describe a "
                    "tumbling vehicle, not a planar manoeuvre; check the restoring moment "
                    "(CG below CB) and the added-mass (Munk) coupling"
                )
                break
    return out


__all__ = [
    "RESPONSES",
    "RESPONSE_NAMES",
    "Manoeuvre",
    "Plan",
    "Response",
    "ResponseError",
    "ResponseValue",
    "attitude_warnings",
    "evaluate",
    "measure",
    "plan",
    "simulate_plan",
    "thrust_reach",
    "time_constant",
]
