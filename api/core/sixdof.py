"""What the 6-DOF route and the ``rig sixdof`` command share: plugging stored estimates in,
one vehicle's detail and the simulation summary (vehicle files are found by
``api.core.vehicle_files``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Annotated, Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from api.core.vehicle_files import find_vehicle
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.procedures.procedure_request import comma_separated_floats
from daq.store import ResultInfo, Store
from estimation.vehicle.apply_estimates import apply_result_json
from estimation.vehicle.description import DOFS, Vehicle6
from estimation.vehicle.dynamics import allocation_matrix

if TYPE_CHECKING:  # the simulation (scipy.integrate) is loaded when one is run, not by an
    # estimate that only looks a vehicle file up
    from estimation.vehicle.simulation import Trajectory

#: Trajectories sent back hold at most this many samples.
MAX_POINTS = 2000


#: Longest simulation one request runs, s.
MAX_DURATION_S = 600.0
#: Most samples one simulation may produce (duration_s / dt).
MAX_SAMPLES = 200_000
#: Right-hand-side evaluations one request may cost (≈ 5 s): a violent input is refused.
MAX_EVALUATIONS = 1_000_000
_Force = Annotated[float, Field(ge=-1e5, le=1e5)]
_Pose = Annotated[float, Field(ge=-1e4, le=1e4)]
_Speed = Annotated[float, Field(ge=-100, le=100)]


class SimulateRequest(BaseModel):
    """A 6-DOF simulation from rest (or from ``eta0``/``nu0``) with constant inputs."""

    model_config = ConfigDict(strict=True, extra="forbid")

    vehicle: str = Field(description="Vehicle name (GET /api/vehicles), e.g. 'seed002-rov'.")
    commands: Annotated[
        list[Annotated[float, Field(ge=-1e6, le=1e6)]] | None,
        Flag("--commands", metavar="U1,U2,...", parse=comma_separated_floats),
    ] = Field(None, description="One command per thruster (|u| ≤ its max_command), held constant.")
    force: Annotated[
        Annotated[list[_Force], Field(min_length=6, max_length=6)] | None,
        Flag("--force", metavar="X,Y,Z,K,M,N", parse=comma_separated_floats),
    ] = Field(
        None, description="Generalized body force X, Y, Z (N), K, M, N (N·m); adds to commands."
    )
    duration_s: Annotated[float, Flag("--duration")] = Field(
        30.0, gt=0, le=MAX_DURATION_S, description="Simulated time, s."
    )
    dt: Annotated[float, Flag("--dt", metavar="S")] = Field(
        0.01, ge=0.001, le=1.0, description="Output sample step, s."
    )
    eta0: Annotated[list[_Pose], Field(min_length=6, max_length=6)] | None = Field(
        None, description="Initial x, y, z (m), φ, θ, ψ (rad), earth frame (NED)."
    )
    nu0: Annotated[list[_Speed], Field(min_length=6, max_length=6)] | None = Field(
        None, description="Initial u, v, w (m/s), p, q, r (rad/s), body frame."
    )
    estimates: list[Annotated[int, Field(ge=1, le=2**62)]] = Field(
        default_factory=list,
        max_length=12,
        description="Stored estimation result ids to plug in (surge/yaw …), in order.",
    )

    @model_validator(mode="after")
    def _bounded_samples(self) -> SimulateRequest:
        """At most ``MAX_SAMPLES`` output samples (named as the field ``dt``)."""
        if self.duration_s / self.dt > MAX_SAMPLES:
            shortest = self.duration_s / MAX_SAMPLES
            allowed = f"≥ duration_s / {MAX_SAMPLES} = {shortest:g} s for {self.duration_s:g} s"
            raise ParameterError([("dt", self.dt, allowed)])
        return self


def vehicle_detail(name: str) -> dict[str, Any]:
    """Parameters, coefficients, thrusters and allocation matrix of one vehicle."""
    v = find_vehicle(name)
    return {
        "name": name,
        "file": v.source,
        "dofs": list(DOFS),
        "vehicle": v.to_json(),
        "allocation_matrix": allocation_matrix(v).tolist(),
    }


def stored_estimates(store: Store, result_ids: Sequence[int]) -> list[ResultInfo]:
    """The stored estimation results named by ``estimates``, in order: ``ResultNotFound``
    for an unknown id, ``ValueError`` naming the field for a result of another kind."""
    found = []
    for result_id in result_ids:
        result = store.result(result_id)
        if result.kind != "estimation":
            raise ValueError(
                f"estimates: result {result_id} is a {result.kind!r} result, "
                "allowed: estimation results"
            )
        found.append(result)
    return found


def apply_results(vehicle: Vehicle6, results: Sequence[ResultInfo]) -> tuple[Vehicle6, list]:
    """Plug stored estimation results into the vehicle, in order."""
    applied = []
    for result_id, data in ((r.id, r.data) for r in results):
        vehicle = apply_result_json(vehicle, data, f"result {result_id}")
        axis = data.get("dof") or data["axis"]  # a tow imported as heave plugs into heave
        applied.append(
            {
                "result_id": result_id,
                "axis": axis,
                "added_mass": vehicle.coefficients()[f"added_mass.{axis}"],
                "linear_damping": vehicle.coefficients()[f"linear_damping.{axis}"],
                "quadratic_damping": vehicle.coefficients()[f"quadratic_damping.{axis}"],
            }
        )
    return vehicle, applied


def run(
    vehicle: Vehicle6,
    duration_s: float,
    *,
    commands: Sequence[float] | None,
    force: Sequence[float] | None,
    dt: float,
    eta0: Sequence[float] | None = None,
    nu0: Sequence[float] | None = None,
    max_points: int = MAX_POINTS,
    max_evaluations: int | None = None,
) -> tuple[Trajectory, dict[str, Any]]:
    """Simulate with constant inputs; the trajectory and a JSON summary (steady values,
    final pose, applied τ, trajectory decimated to ≤ ``max_points`` samples)."""
    from estimation.vehicle.simulation import simulate, steady_state

    if commands is None and force is None and eta0 is None and nu0 is None:
        raise ValueError(
            "commands: got None, allowed: per-thruster commands or a force (6 values) "
            "or an initial state"
        )
    traj = simulate(
        vehicle,
        duration_s,
        commands=None if commands is None else np.asarray(commands, dtype=float),
        force=None if force is None else np.asarray(force, dtype=float),
        dt=dt,
        eta0=eta0,
        nu0=nu0,
        max_evaluations=max_evaluations,
    )
    every = max(1, math.ceil(len(traj.t) / (max_points - 1)))
    steady = steady_state(traj)
    summary = {
        "vehicle": vehicle.name,
        "duration_s": float(traj.t[-1]),
        "dt": dt,
        "samples": len(traj.t),
        "every": every,
        "tau": dict(zip(("X", "Y", "Z", "K", "M", "N"), traj.tau[0].tolist(), strict=True)),
        "steady": steady.to_json(),
        "final_eta": dict(
            zip(("x", "y", "z", "phi", "theta", "psi"), traj.eta[-1].tolist(), strict=True)
        ),
        "trajectory": traj.to_json(every=every),
    }
    return traj, summary


def simulated_summary(vehicle: Vehicle6, duration_s: float, **options: Any) -> dict[str, Any]:
    """The JSON summary of :func:`run` alone (what crosses back from the analysis worker
    process: the trajectory object stays there)."""
    return run(vehicle, duration_s, **options)[1]
