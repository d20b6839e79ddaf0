"""The simulated rig's physics: carriage, yaw, tow/spin weights, thrusters, load cell.

Fixed-step integration (1 ms, semi-implicit Euler) independent of polling:
``advance_to(t_mono)`` integrates whole steps up to that time, so the plant's
history does not depend on how often anyone reads it. Equations (SI units):

* tow, rigid rope: ``(M + m_w + J_p/r_p²) v̇ = d·m_w g + T_x + F_bias − k x − K_L v − K_Q|v|v
  − c v³ − F_c sgn v``
* tow, elastic rope (stiffness k_r, damping c_r): the weight is its own body,
  ``(m_w + J_p/r_p²) ü = m_w g − R``, ``M v̇ = d·R + …`` with
  ``R = max(0, k_r d(y − x) + c_r d(u − v))``
* d = −1 when the tow line runs over the far-end pulley (``sim_tow_reversed``: the weight
  pulls the carriage back toward the start), +1 otherwise; likewise the spin cord wound the
  other way round the drum (``sim_spin_reversed``) turns the vehicle negative
* yaw: ``(I + m_s r_d² + J_d) ω̇ = d·m_s g r_d + τ_thr + τ_bias − k_θ θ − K_L ω − K_Q|ω|ω − c_θ ω³
  − τ_c sgn ω`` (the weight term drops once the cord has run out)
* thruster i: ``T_ss = F_fs · s^p · (V/V_nom)^q`` with ``s = (|u| − d)/(1 − d)`` above the dead
  band d (reverse × ratio), and ``Ṫ = (T_ss − T)/τ_T``
* pendulum (rig files with ``[pendulum]``): ``daq.sim.pendulum_plant``, stepped with the rest

The channels the simulated PLC reads and writes map onto this state in
``daq.sim.plant_channels``.
"""

from __future__ import annotations

import math
import random

from daq.config import RigConfig
from daq.sim.friction import sign, stick_slip_step
from daq.sim.pendulum_plant import SimPendulum
from daq.sim.scenario import Scenario
from thrusters.settings import ThrusterPort

STEP_S = 0.001


class Plant:
    """Physics of the rig; the simulated PLC reads and writes it by channel name."""

    def __init__(self, rig: RigConfig, scenario: Scenario | None = None) -> None:
        self.rig = rig
        self.scenario = scenario or Scenario()
        #: The sensor noise (load cell, supply voltage), seeded by the scenario.
        self.sensor_noise = random.Random(self.scenario.seed)
        geo, thr = rig.geometry, self.scenario.thrusters
        #: The rig's thrusters; a rig without [thrusters] gets the default ones, never commanded.
        self.thruster_port = rig.thrusters or ThrusterPort()
        self.g = rig.rig.g
        self.full_scale_thrust_n = thr.full_scale_thrust_n or self.thruster_port.full_scale_thrust_n
        self._pulley_mass = geo.pulley_inertia_kg_m2 / geo.pulley_radius_m**2
        self._thrust_alpha = (
            1.0 if thr.time_constant_s == 0 else 1.0 - math.exp(-STEP_S / thr.time_constant_s)
        )
        # Port thrusters (even index) turn the vehicle positive, starboard (odd) negative.
        self._yaw_sign = self.thruster_port.yaw_signs()
        self.t_start: float | None = None
        self.steps = 0
        self.estop = False
        self.tow_weight_kg = 0.0
        self.spin_weight_kg = 0.0
        self.thrust_stand = False
        #: The tow line over the far-end pulley / the spin cord wound the other way: the
        #: weight pulls (turns) negative. ``reset`` rigs both the normal way again.
        self.tow_reversed = False
        self.spin_reversed = False
        n = self.thruster_port.count
        self.commands = [0.0] * n
        self.thrusts_n = [0.0] * n
        self._no_thrust = [0.0] * n
        self.tow_release_at: float | None = None
        self.spin_release_at: float | None = None
        self.tow_release = False
        self.spin_release = False
        #: The free-decay pendulum, when the rig file has one (``daq.sim.pendulum_plant``).
        self.pendulum = SimPendulum(rig, self.scenario) if rig.pendulum is not None else None
        self.reset()

    # ---- state ---------------------------------------------------------------------------
    def reset(self, position_m: float = 0.0) -> None:
        """Carriage to ``position_m`` (0 m: the start) and yaw to 0 rad, at rest, both brakes
        engaged, the tow line over the near pulley and the spin cord wound the normal way."""
        self.position_m = position_m
        self.tow_reversed = False
        self.spin_reversed = False
        self.velocity_m_s = 0.0
        self.yaw_rad = 0.0
        self.yaw_rate_rad_s = 0.0
        self.tow_braked = True
        self.spin_braked = True
        self.tow_release = False
        self.spin_release = False
        self.tow_release_at = None
        self.spin_release_at = None
        self.hang_weight_at_rest()
        if self.pendulum is not None:
            self.pendulum.reset()

    def hang_weight_at_rest(self) -> None:
        """The hung weight back on its support, at rest under the carriage."""
        # The weight rests on its support with the rope just taut until the brake lets go
        # (the PLC drops the support with the brake), so an elastic rope starts unstretched.
        self.weight_supported = True
        self.weight_position_m = self.position_m
        self.weight_velocity_m_s = 0.0

    @property
    def sim_time_s(self) -> float:
        """Simulated time since the first ``advance_to``, s."""
        return self.steps * STEP_S

    @property
    def end_of_travel(self) -> bool:
        """The end-of-travel switch is tripped."""
        return self.position_m >= self.rig.geometry.end_of_travel_m

    @property
    def cord_out(self) -> bool:
        """The spin cord has fully unwound (the drum weight no longer pulls)."""
        turned = -self.yaw_rad if self.spin_reversed else self.yaw_rad
        return turned >= self.rig.geometry.spin_max_angle_rad

    @property
    def tow_direction(self) -> float:
        """+1: the hung weight pulls toward the far end; −1: over the far-end pulley, back."""
        return -1.0 if self.tow_reversed else 1.0

    # ---- time ----------------------------------------------------------------------------
    def advance_to(self, t_mono: float) -> int:
        """Integrate whole 1 ms steps up to monotonic time ``t_mono``; returns steps taken."""
        if self.t_start is None:
            self.t_start = t_mono
            return 0
        # whole steps, with the quotient's round-off forgiven: 12.3 s / 1 ms is 12299.999…
        # in floating point, and a plain int() put the plant (its clock, and a release
        # written then) a step behind the host's time half the time: a release 1 ms early
        target = int((t_mono - self.t_start) / STEP_S + 1e-6)
        n = target - self.steps
        if n <= 0:
            return 0
        for i in range(n):
            if self._quiescent():
                self.steps += n - i
                break
            self.steps += 1
            self._step()
        return n

    def advance(self, seconds: float) -> None:
        """Integrate ``seconds`` of simulated time (tests and offline use)."""
        if self.t_start is None:
            self.t_start = 0.0
        self.advance_to(self.t_start + (self.steps + round(seconds / STEP_S) + 0.5) * STEP_S)

    def _quiescent(self) -> bool:
        """Nothing can change until an outside write: skip integration."""
        if self.pendulum is not None and not self.pendulum.quiescent:
            return False
        if not (self.tow_braked and self.spin_braked):
            return False
        if self.tow_release_at is not None or self.spin_release_at is not None:
            return False
        k_rope = self.scenario.effects.rope_stiffness_n_per_m
        if k_rope > 0 and self.tow_weight_kg > 0 and not self.weight_supported:
            stretch = self.tow_direction * (self.weight_position_m - self.position_m)
            unbalanced = self.tow_weight_kg * self.g - k_rope * stretch
            if abs(self.weight_velocity_m_s) > 1e-9 or abs(unbalanced) > 1e-6:
                return False
        v = self.loaded_voltage_v()
        return all(
            abs(self.static_thrust_n(u, v) - t) < 1e-9
            for u, t in zip(self.commands, self.thrusts_n, strict=True)
        )

    # ---- one step ------------------------------------------------------------------------
    def _step(self) -> None:
        t = self.steps * STEP_S
        if self.tow_release_at is not None and t >= self.tow_release_at:
            self.tow_release_at = None
            self.tow_braked = False
            self.weight_supported = False
        if self.spin_release_at is not None and t >= self.spin_release_at:
            self.spin_release_at = None
            self.spin_braked = False
        thrusts = self.thrusts_n
        lever = self.thruster_port.yaw_lever_arm_m
        if any(self.commands) or any(thrusts):
            volts = self.loaded_voltage_v()
            alpha = self._thrust_alpha
            for i, u in enumerate(self.commands):
                thrusts[i] += (self.static_thrust_n(u, volts) - thrusts[i]) * alpha
            surge_thrust = sum(thrusts)
            yaw_torque = lever * sum(s * f for s, f in zip(self._yaw_sign, thrusts, strict=True))
        else:  # thrusters off and at rest: the same zeros as above, without the arithmetic
            thrusts[:] = self._no_thrust
            surge_thrust, yaw_torque = 0.0, lever * 0.0
        if self.thrust_stand:
            surge_thrust = yaw_torque = 0.0
        self._step_tow(surge_thrust)
        self._step_yaw(yaw_torque)
        if self.pendulum is not None:
            self.pendulum.step(t, STEP_S)

    def _step_tow(self, thrust_n: float) -> None:
        sc, fx = self.scenario.surge, self.scenario.effects
        m_w = self.tow_weight_kg
        k_rope = fx.rope_stiffness_n_per_m
        d = self.tow_direction
        x, v = self.position_m, self.velocity_m_s
        if k_rope > 0 and m_w > 0 and not self.weight_supported:
            # The weight's own coordinate runs along the rail; d turns it to the pull's sense.
            stretch = d * (self.weight_position_m - x)
            rope = k_rope * stretch + fx.rope_damping_n_s_per_m * d * (self.weight_velocity_m_s - v)
            rope = max(0.0, rope) if stretch > 0 else 0.0
            acc_w = d * (m_w * self.g - rope) / (m_w + self._pulley_mass)
            self.weight_velocity_m_s += acc_w * STEP_S
            self.weight_position_m += self.weight_velocity_m_s * STEP_S
            mass = sc.inertia_kg
            pull = d * rope
        else:
            mass = sc.inertia_kg + (m_w + self._pulley_mass if m_w > 0 else 0.0)
            pull = d * m_w * self.g
        if self.tow_braked:
            self.velocity_m_s = 0.0
            if k_rope == 0 or self.weight_supported:
                self.weight_position_m, self.weight_velocity_m_s = x, 0.0
            return
        drive = pull + thrust_n + fx.bias_force_n - fx.spring_n_per_m * x
        force = (
            drive - (sc.linear_damping + sc.quadratic_damping * abs(v) + fx.cubic_drag * v * v) * v
        )
        v_new = self._friction_step(
            v, drive, force, mass, fx.coulomb_friction_n, fx.static_friction_n
        )
        x += v_new * STEP_S
        if x < 0.0 and v_new < 0.0:  # buffer at the start of the rail
            x, v_new = 0.0, 0.0
        self.position_m, self.velocity_m_s = x, v_new
        if k_rope == 0 or m_w == 0:
            self.weight_position_m, self.weight_velocity_m_s = x, v_new
        if self.end_of_travel:
            # The switch trips; the PLC interlock drops tow_release and the brake bites.
            self.velocity_m_s = 0.0
            self.tow_braked = True
            self.tow_release = False
            self.tow_release_at = None
            if k_rope == 0:
                self.weight_velocity_m_s = 0.0

    def _step_yaw(self, thrust_torque_nm: float) -> None:
        if self.spin_braked:
            self.yaw_rate_rad_s = 0.0
            return
        sc, fx, geo = self.scenario.yaw, self.scenario.effects, self.rig.geometry
        th, w = self.yaw_rad, self.yaw_rate_rad_s
        inertia = sc.inertia_kg_m2 + geo.spin_drum_inertia_kg_m2
        weight_torque = 0.0
        r = geo.spin_drum_radius_m
        if self.spin_weight_kg > 0 and not self.cord_out and r is not None:  # a drum to hang on
            inertia += self.spin_weight_kg * r * r
            weight_torque = self.spin_weight_kg * self.g * r * (-1.0 if self.spin_reversed else 1.0)
        drive = weight_torque + thrust_torque_nm + fx.bias_torque_nm - fx.spring_nm_per_rad * th
        damping = sc.linear_damping + sc.quadratic_damping * abs(w) + fx.yaw_cubic_drag * w * w
        torque = drive - damping * w
        w_new = self._friction_step(
            w, drive, torque, inertia, fx.yaw_coulomb_friction_nm, fx.yaw_static_friction_nm
        )
        self.yaw_rad = th + w_new * STEP_S
        self.yaw_rate_rad_s = w_new

    @staticmethod
    def _friction_step(
        v: float, drive: float, force: float, mass: float, coulomb: float, static: float
    ) -> float:
        """One semi-implicit velocity step with stick-slip friction."""
        return stick_slip_step(v, drive, force, mass, coulomb, static, STEP_S)

    # ---- thrusters and supply ------------------------------------------------------------
    def static_thrust_n(self, command: float, supply_v: float) -> float:
        """Steady thrust of one thruster for a command in −1…1 at a supply voltage, N."""
        thr = self.scenario.thrusters
        a = abs(command)
        if a <= thr.dead_band:
            return 0.0
        s = min(1.0, (a - thr.dead_band) / (1.0 - thr.dead_band))
        volts = max(supply_v, 0.0) / thr.nominal_voltage_v
        thrust = self.full_scale_thrust_n * s**thr.curve_exponent * volts**thr.voltage_exponent
        return thrust if command > 0 else -thrust * thr.reverse_ratio

    def thruster_current_a(self, thrust_n: float) -> float:
        """Electrical current drawn by one thruster producing ``thrust_n``, A."""
        thr = self.scenario.thrusters
        return thr.full_scale_current_a * (abs(thrust_n) / self.full_scale_thrust_n) ** 1.5

    def loaded_voltage_v(self) -> float:
        """Supply voltage under the present thruster load (noise-free), V."""
        sens = self.scenario.sensors
        amps = sum(self.thruster_current_a(t) for t in self.thrusts_n)
        return sens.supply_voltage_v - sens.supply_resistance_ohm * amps

    def set_commands(self, fractions: list[float]) -> None:
        """Thruster outputs as fractions of full scale (−1…1), from the serial controller."""
        if len(fractions) != len(self.commands):
            raise ValueError(
                f"thruster commands: expected {len(self.commands)} values, got {len(fractions)}"
            )
        self.commands = [0.0 if self.estop else max(-1.0, min(1.0, float(u))) for u in fractions]

    def telemetry(self) -> list[tuple[float, float]]:
        """Per thruster: (propeller speed in rpm, signed like thrust; current in A)."""
        thr = self.scenario.thrusters
        out = []
        for t in self.thrusts_n:
            rpm = thr.full_scale_rpm * math.sqrt(abs(t) / self.full_scale_thrust_n) * sign(t)
            out.append((rpm, self.thruster_current_a(t)))
        return out

    # ---- brakes and stop (the channels the PLC serves: ``daq.sim.plant_channels``) -------
    def engage_tow_brake(self) -> None:
        """Drop the tow release: the brake holds the carriage at once (speed 0 m/s)."""
        self.tow_release, self.tow_release_at, self.tow_braked = False, None, True
        self.velocity_m_s = 0.0

    def engage_spin_brake(self) -> None:
        """Drop the spin release: the brake holds the turntable at once (0 rad/s)."""
        self.spin_release, self.spin_release_at, self.spin_braked = False, None, True
        self.yaw_rate_rad_s = 0.0

    def press_estop(self, pressed: bool = True) -> None:
        """Emergency stop: brakes engage, releases drop, thruster commands go to zero."""
        self.estop = pressed
        if pressed:
            self.engage_tow_brake()
            self.engage_spin_brake()
            self.commands = [0.0] * len(self.commands)

    # ---- closed-form helpers -------------------------------------------------------------
    def steady_tow_speed(self, force_n: float) -> float:
        """Steady carriage speed (m/s) under a constant force with this scenario's damping."""
        sc, fx = self.scenario.surge, self.scenario.effects
        net = force_n + fx.bias_force_n
        if abs(net) <= max(fx.coulomb_friction_n, fx.static_friction_n):
            return 0.0
        target = abs(net) - fx.coulomb_friction_n

        def resist(v: float) -> float:
            return sc.linear_damping * v + sc.quadratic_damping * v * v + fx.cubic_drag * v**3

        lo, hi = 0.0, 1.0
        while resist(hi) < target:
            hi *= 2
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if resist(mid) < target else (lo, mid)
        return math.copysign(0.5 * (lo + hi), net)
