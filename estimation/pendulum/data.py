"""A pendulum free-decay run as the estimators see it: arrays plus rig geometry.

The rig swings the vehicle on a rod about a horizontal pivot; the moment balance
(rotational form, seed002 eq. 168–169) is

    (J_t + m_z·l² + J_v + α·l²)·φ̈ = −[(m_z − ρV)·l + m_t·r]·g·sin φ
                                     − (β·l² + b)·φ̇ − γ·l³·|φ̇|·φ̇ − τ_c·sgn φ̇

with α, β, γ the added mass (kg), linear (N·s/m) and quadratic (kg/m) damping of the
vehicle along the swing axis and τ_c a dry-friction torque in the pivot (N·m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimation.data.run_arrays import field_error, validate_series

SWING_AXES: tuple[str, ...] = ("surge", "sway", "heave")
MIN_DECAY_SAMPLES = 20


@dataclass(frozen=True)
class PendulumGeometry:
    """What is known about the pendulum before the run (SI units).

    ``pivot_to_vehicle_m`` l (m): pivot to the vehicle's CG. ``rod_mass_kg`` m_t (kg),
    ``rod_cg_m`` r (m): pivot to the rod's CG, ``rod_inertia_kg_m2`` J_t: rod (+ clamp)
    about the pivot. ``vehicle_mass_kg`` m_z, ``vehicle_inertia_kg_m2`` J_v: the vehicle
    about its own CG, about the swing axis. ``buoyancy_kg`` ρ·V: mass of the displaced
    water, acting at the vehicle CG. ``pivot_damping_nm_s`` b: known viscous torque of
    pivot + rod per rad/s (0 if not measured). ``g`` (m/s²).
    """

    pivot_to_vehicle_m: float
    rod_mass_kg: float
    rod_cg_m: float
    rod_inertia_kg_m2: float
    vehicle_mass_kg: float
    vehicle_inertia_kg_m2: float
    buoyancy_kg: float
    pivot_damping_nm_s: float
    g: float

    def known_inertia(self) -> float:
        """J_known = J_t + m_z·l² + J_v (kg·m²): everything but the added mass."""
        arm = self.pivot_to_vehicle_m
        return self.rod_inertia_kg_m2 + self.vehicle_mass_kg * arm**2 + self.vehicle_inertia_kg_m2

    def restoring_stiffness(self) -> float:
        """k = [(m_z − ρV)·l + m_t·r]·g (N·m/rad): restoring moment per sin φ."""
        arm = self.pivot_to_vehicle_m
        wet = (self.vehicle_mass_kg - self.buoyancy_kg) * arm + self.rod_mass_kg * self.rod_cg_m
        return wet * self.g


@dataclass(frozen=True)
class PendulumRun:
    """One free-decay record: ``t`` (s), pivot ``angle`` φ (rad), released at ``t_release``.

    Samples before ``t_release`` are the held pendulum (ignored by the fits).
    ``axis`` names the vehicle axis that swings through the water; ``t_release_std`` how
    well the release instant is known (1σ, s).
    """

    run_id: str
    t: np.ndarray
    angle: np.ndarray
    t_release: float
    geometry: PendulumGeometry
    axis: str = "surge"
    t_release_std: float = 0.0

    def decay(self) -> tuple[np.ndarray, np.ndarray]:
        """(t, angle) of the samples at and after release."""
        t = np.asarray(self.t, dtype=float)
        keep = t >= self.t_release
        return t[keep], np.asarray(self.angle, dtype=float)[keep]


def validate_geometry(geometry: PendulumGeometry, run_id: str = "") -> None:
    """Raise ValueError naming the field, the value and the allowed range."""
    g = geometry
    positive = {
        "geometry.pivot_to_vehicle_m": (g.pivot_to_vehicle_m, "> 0 m"),
        "geometry.vehicle_mass_kg": (g.vehicle_mass_kg, "> 0 kg"),
        "geometry.g": (g.g, "> 0 m/s²"),
    }
    for field, (value, allowed) in positive.items():
        if not (np.isfinite(value) and value > 0):
            raise field_error(run_id, field, value, allowed)
    non_negative = {
        "geometry.rod_mass_kg": (g.rod_mass_kg, ">= 0 kg"),
        "geometry.rod_cg_m": (g.rod_cg_m, ">= 0 m"),
        "geometry.rod_inertia_kg_m2": (g.rod_inertia_kg_m2, ">= 0 kg·m²"),
        "geometry.vehicle_inertia_kg_m2": (g.vehicle_inertia_kg_m2, ">= 0 kg·m²"),
        "geometry.buoyancy_kg": (g.buoyancy_kg, ">= 0 kg"),
        "geometry.pivot_damping_nm_s": (g.pivot_damping_nm_s, ">= 0 N·m·s"),
    }
    for field, (value, allowed) in non_negative.items():
        if not (np.isfinite(value) and value >= 0):
            raise field_error(run_id, field, value, allowed)
    if not g.restoring_stiffness() > 0:
        raise field_error(
            run_id,
            "geometry.buoyancy_kg",
            g.buoyancy_kg,
            "small enough that [(m_z − ρV)·l + m_t·r]·g > 0 (the pendulum must hang down)",
        )


def validate_pendulum_run(run: PendulumRun) -> None:
    """Raise ValueError naming the field, the value and what is allowed when a run is unusable."""
    rid = run.run_id
    validate_geometry(run.geometry, rid)
    if run.axis not in SWING_AXES:
        raise field_error(rid, "axis", run.axis, f"one of {list(SWING_AXES)}")
    t = validate_series(rid, run.t, run.angle, "angle", "finite angles (rad)")
    phi = np.asarray(run.angle)
    if not (np.isfinite(run.t_release_std) and run.t_release_std >= 0):
        raise field_error(rid, "t_release_std", run.t_release_std, ">= 0 s")
    if t.size == 0 or not (t[0] <= run.t_release <= t[-1]):
        lo, hi = (t[0], t[-1]) if t.size else (np.nan, np.nan)
        raise field_error(rid, "t_release", run.t_release, f"within [{lo:g}, {hi:g}] s")
    after = int(np.count_nonzero(t >= run.t_release))
    if after < MIN_DECAY_SAMPLES:
        raise field_error(rid, "t", f"{after} samples after release", f">= {MIN_DECAY_SAMPLES}")
    swing = phi[t >= run.t_release]
    if np.max(np.abs(swing)) > np.pi / 2:
        raise field_error(
            rid, "angle", float(np.max(np.abs(swing))), "|φ| <= π/2 rad after release"
        )
