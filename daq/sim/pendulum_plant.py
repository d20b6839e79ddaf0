"""The simulated pendulum: the vehicle on a rod, swinging through the water (seed 002).

Rotational moment balance about the pivot (seed 002 eq. 168–169, with the pivot's dry
friction), integrated with the plant's fixed 1 ms semi-implicit Euler step::

    J φ̈ = −k sin φ − (β l² + b) φ̇ − γ l³ |φ̇| φ̇ − τ_c sgn φ̇
    J = J_t + m_z l² + J_v + α l²        k = [(m_z − ρV) l + m_t r] g

α, β, γ are the vehicle's added mass and linear and quadratic damping along the swing
axis: the scenario's ``surge`` coefficients (the same as the tow: α = (m + m_a) − m_z),
or its ``sway`` / ``heave`` sections. τ_c is the scenario's ``pivot_coulomb_friction_nm``
(break-away at ``pivot_static_friction_nm``).

The release latch: with ``pendulum_release`` off the pendulum is held at rest where the
operator put it (``sim_pendulum_angle``); on, it swings (after the scenario's release
delay); off again, it is caught and held at rest where it was.
"""

from __future__ import annotations

import math
import random

from daq.config import RigConfig
from daq.sim.friction import stick_slip_step
from daq.sim.scenario import Scenario


class SimPendulum:
    """The pendulum's state and physics; the plant steps it, the PLC reads and writes it."""

    CHANNELS = ("pendulum_angle", "pendulum_release", "sim_pendulum_angle")

    def __init__(self, rig: RigConfig, scenario: Scenario) -> None:
        p = rig.pendulum
        if p is None:
            raise ValueError("the rig file has no [pendulum] section")
        coefficients = scenario.surge if p.axis == "surge" else getattr(scenario, p.axis)
        if coefficients is None:
            raise ValueError(
                f"scenario: the pendulum swings along {p.axis}; "
                f"give a [{p.axis}] section (inertia_kg, linear_damping, quadratic_damping)"
            )
        m_z, arm = rig.vehicle.dry_mass_kg, p.pivot_to_vehicle_m
        self.added_mass_kg = coefficients.inertia_kg - m_z
        if self.added_mass_kg < 0:
            raise ValueError(
                f"scenario: {p.axis}.inertia_kg ({coefficients.inertia_kg:g} kg) is the vehicle's "
                f"mass plus added mass; it must be at least the vehicle's {m_z:g} kg"
            )
        self.max_angle_rad = p.max_angle_rad
        #: J: everything that swings, about the pivot, kg·m².
        self.inertia_kg_m2 = (
            p.rod_inertia_kg_m2
            + m_z * arm * arm
            + p.vehicle_inertia_kg_m2
            + self.added_mass_kg * arm * arm
        )
        #: k: restoring torque per sin φ, N·m.
        self.restoring_nm = ((m_z - p.buoyancy_kg) * arm + p.rod_mass_kg * p.rod_cg_m) * rig.rig.g
        #: β l² + b, N·m·s/rad, and γ l³, N·m·s²/rad².
        self.linear_nm_s = coefficients.linear_damping * arm * arm + p.pivot_damping_nm_s
        self.quadratic_nm_s2 = coefficients.quadratic_damping * arm**3
        fx, sens = scenario.effects, scenario.sensors
        self.coulomb_nm = fx.pivot_coulomb_friction_nm
        self.static_nm = fx.pivot_static_friction_nm
        self.release_delay_s = fx.release_delay_s
        self.counts_per_rad = sens.pendulum_counts_per_rad
        self.noise_rad = sens.pendulum_angle_noise_rad
        self._rng = random.Random(scenario.seed + 2)
        self.reset()

    def reset(self) -> None:
        """Hanging plumb at rest, latched."""
        self.angle_rad = 0.0
        self.rate_rad_s = 0.0
        self.hold_angle_rad = 0.0
        self.released = False
        self._release_at: float | None = None
        self.free = False

    # ---- physics ---------------------------------------------------------------------------
    def step(self, t: float, dt: float) -> None:
        """One integration step of ``dt`` seconds at simulated time ``t``."""
        if self._release_at is not None and t >= self._release_at:
            self._release_at, self.free = None, True
        if not self.free:
            return
        phi, w = self.angle_rad, self.rate_rad_s
        drive = -self.restoring_nm * math.sin(phi)
        torque = drive - (self.linear_nm_s + self.quadratic_nm_s2 * abs(w)) * w
        w_new = stick_slip_step(
            w, drive, torque, self.inertia_kg_m2, self.coulomb_nm, self.static_nm, dt
        )
        self.angle_rad = phi + w_new * dt
        self.rate_rad_s = w_new

    @property
    def quiescent(self) -> bool:
        """Nothing changes until an outside write: held, or stuck by the pivot's friction."""
        if self._release_at is not None:
            return False
        if not self.free:
            return True
        breakaway = self.static_nm or self.coulomb_nm
        return self.rate_rad_s == 0.0 and abs(self.restoring_nm * math.sin(self.angle_rad)) <= (
            breakaway
        )

    def energy_j(self) -> float:
        """Kinetic plus potential energy (zero hanging at rest), J."""
        kinetic = 0.5 * self.inertia_kg_m2 * self.rate_rad_s**2
        return kinetic + self.restoring_nm * (1.0 - math.cos(self.angle_rad))

    def small_angle_period_s(self) -> float:
        """Damped period of the linearised swing (no quadratic drag, no dry friction), s."""
        omega0_sq = self.restoring_nm / self.inertia_kg_m2
        decay = self.decay_rate_1_s()
        return 2 * math.pi / math.sqrt(omega0_sq - decay * decay)

    def decay_rate_1_s(self) -> float:
        """K = (β l² + b) / (2 J): the envelope ``e^{−K t}`` of the linear swing, 1/s."""
        return self.linear_nm_s / (2 * self.inertia_kg_m2)

    # ---- channels --------------------------------------------------------------------------
    def read(self, name: str) -> float | None:
        """SI value of a pendulum channel (None: not a pendulum channel)."""
        if name == "pendulum_angle":
            counts = round(self.angle_rad * self.counts_per_rad) / self.counts_per_rad
            return counts + (self._rng.gauss(0.0, self.noise_rad) if self.noise_rad else 0.0)
        if name == "pendulum_release":
            return 1.0 if self.released else 0.0
        if name == "sim_pendulum_angle":
            return self.hold_angle_rad
        return None

    def write(self, name: str, value: float, t: float) -> bool:
        """Apply a write at simulated time ``t``; False if not a pendulum channel."""
        if name == "pendulum_release":
            if value and not self.released:
                self.released, self._release_at = True, t + self.release_delay_s
            elif not value:
                # Caught: held at rest where it was, until the operator moves it.
                self.released, self._release_at, self.free = False, None, False
                self.rate_rad_s, self.hold_angle_rad = 0.0, self.angle_rad
        elif name == "sim_pendulum_angle":
            if math.isnan(value) or abs(value) > self.max_angle_rad:
                raise ValueError(
                    f"sim_pendulum_angle: must be within ±{self.max_angle_rad:g} rad "
                    f"(max_angle_rad), got {value}"
                )
            # The operator pulls the pendulum out and holds it there at rest.
            self.angle_rad = self.hold_angle_rad = float(value)
            self.rate_rad_s = 0.0
        else:
            return False
        return True
