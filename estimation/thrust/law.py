"""Thrust as a function of command and supply voltage, identified from calibrations.

Per supply voltage, the calibrated curve (``CalibratedThrust``: the fitted per-side curve
corrected to the measured thrusts). Between voltages, the thrust at a fixed command is
interpolated across voltage with a monotone cubic (PCHIP; linear with two voltages).
Why not a power law V^q: published multi-voltage bollard data (Blue Robotics T200, 10–20 V)
give a local exponent that falls from ≈ 1.3 at 10–12 V to ≈ 0.4 at 18–20 V, so no single q
fits; a monotone interpolant follows that without a model of the drive electronics.

σ of a force: the calibration's scatter about its curve (fit RMSE at the nearest
voltages) ⊕ the interpolation's own error, measured by leaving each interior voltage out
and predicting it from the others (relative to the full thrust, scaled by |F|).
With one voltage only, the voltage law is *assumed*: F ∝ V^q, q = 1.0 ± 0.5
(``ASSUMED_EXPONENT``), and that uncertainty is carried into σ. Outside the calibrated
voltages the nearest curve is scaled by that assumed law too.

Saturation: a command beyond the calibrated range gives the thrust at the range's end
(the controller's full command); the inverse refuses forces beyond what full command
delivers at the voltage asked for, naming that force.

Low end: the inverse also refuses a non-zero force below the smallest calibrated thrust on
its side (the law at the smallest command where the calibrations at that voltage measured
thrust beyond their last reading of none), naming that thrust. Below it the curve is
extrapolated into the dead band, where the thrust is not proportional to anything
measured and a small command error means no thrust at all; a refusal says to calibrate
smaller commands, a warning would let a test run on a drive nobody measured.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from estimation.thrust.curve import CalibratedThrust, fit_thrust_curve

#: The voltage law assumed when calibrations cover one supply voltage: exponent and σ.
ASSUMED_EXPONENT = (1.0, 0.5)
#: Voltages closer than this are one calibration voltage, V.
VOLTAGE_TOLERANCE_V = 0.25


@dataclass(frozen=True)
class ThrustEstimate:
    """A value with σ and how the voltage dependence was obtained."""

    value: float
    std: float
    voltage_law: str

    def to_json(self) -> dict:
        return {"value": self.value, "std": self.std, "voltage_law": self.voltage_law}


@dataclass(frozen=True)
class ThrustLaw:
    """F(command, V) from per-voltage calibrated curves (see module docstring)."""

    voltages: np.ndarray
    curves: tuple[CalibratedThrust, ...]
    #: Leave-one-voltage-out interpolation error, fraction of full thrust (0: not measured).
    interpolation_error: float = 0.0
    assumed_exponent: tuple[float, float] = ASSUMED_EXPONENT
    held_out: dict = field(default_factory=dict)

    @property
    def command_range(self) -> tuple[float, float]:
        """Commands every voltage's calibration covers (beyond: saturated)."""
        lo = max(c.curve.command_min for c in self.curves)
        hi = min(c.curve.command_max for c in self.curves)
        return lo, hi

    @property
    def identified(self) -> bool:
        """True when the voltage dependence comes from data (≥ 2 voltages)."""
        return len(self.curves) >= 2

    @property
    def reference_voltage(self) -> float:
        """The voltage of the calibration (the highest one with several)."""
        return float(self.voltages[-1])

    def voltage_law(self, volts: float) -> str:
        """How the thrust at ``volts`` is obtained, in words."""
        q, sq = self.assumed_exponent
        lo, hi = float(self.voltages[0]), float(self.voltages[-1])
        if not self.identified:
            return f"assumed: F ∝ V^{q:g} ± {sq:g} from the calibration at {lo:g} V"
        if volts < lo - VOLTAGE_TOLERANCE_V or volts > hi + VOLTAGE_TOLERANCE_V:
            return (
                f"extrapolated: outside the calibrated {lo:g} … {hi:g} V, "
                f"F ∝ V^{q:g} ± {sq:g} assumed from the nearest calibration"
            )
        return f"identified from calibrations at {', '.join(f'{v:g}' for v in self.voltages)} V"

    def _full(self) -> float:
        lo, hi = self.command_range
        return max(abs(float(c.force(u))) for c in self.curves for u in (lo, hi))

    def _at_voltages(self, u: np.ndarray) -> np.ndarray:
        """Thrust at each calibrated voltage (rows) for the saturated commands ``u``."""
        return np.array([c.force(u) for c in self.curves])

    def force(
        self, command: float | np.ndarray, volts: float | np.ndarray | None = None
    ) -> np.ndarray:
        """Thrust of one thruster, N, at ``command`` (fraction, saturated to the calibrated
        range) and supply ``volts`` (None: the reference voltage)."""
        lo, hi = self.command_range
        u = np.clip(np.asarray(command, dtype=float), lo, hi)
        v = np.broadcast_to(
            np.asarray(self.reference_voltage if volts is None else volts, dtype=float), u.shape
        )
        # Commands repeat (a drive holds each output for many instants): one interpolant
        # across voltage per distinct command.
        commands, which = np.unique(u.ravel(), return_inverse=True)
        table = self._at_voltages(commands)  # (voltages, distinct commands)
        v_lo, v_hi = float(self.voltages[0]), float(self.voltages[-1])
        q = self.assumed_exponent[0]
        flat_v = v.ravel()
        if not self.identified:
            return (table[0][which] * (flat_v / v_lo) ** q).reshape(u.shape)
        from scipy.interpolate import PchipInterpolator  # loaded by the first thruster run

        inside = np.clip(flat_v, v_lo, v_hi)
        out = np.empty_like(inside)
        for k in range(commands.size):
            at = which == k
            if len(self.curves) == 2:
                out[at] = np.interp(inside[at], self.voltages, table[:, k])
            else:
                out[at] = PchipInterpolator(self.voltages, table[:, k])(inside[at])
        return (out * (flat_v / inside) ** q).reshape(u.shape)

    def estimate(self, command: float, volts: float | None = None) -> ThrustEstimate:
        """Thrust ± σ at one command and voltage."""
        v = self.reference_voltage if volts is None else float(volts)
        f = float(self.force(command, v))
        near = int(np.argmin(np.abs(self.voltages - v)))
        scatter = self.curves[near].curve.rmse_n
        var = scatter**2 + (self.interpolation_error * abs(f)) ** 2
        lo, hi = float(self.voltages[0]), float(self.voltages[-1])
        edge = min(max(v, lo), hi)
        if not self.identified or abs(v - edge) > VOLTAGE_TOLERANCE_V:
            var += (abs(f) * abs(math.log(v / edge)) * self.assumed_exponent[1]) ** 2
        return ThrustEstimate(f, math.sqrt(var), self.voltage_law(v))

    def max_force(self, volts: float | None, sign: float = 1.0) -> float:
        """The largest thrust (sign > 0) or reverse thrust (sign < 0) full command delivers."""
        lo, hi = self.command_range
        return float(self.force(hi if sign > 0 else lo, volts))

    def _bracket(self, volts: float) -> list[int]:
        """The calibrations a force at ``volts`` comes from: the one at that voltage, else
        its neighbours on either side (the nearest outside the calibrated range)."""
        gaps = np.abs(self.voltages - volts)
        if gaps.min() <= VOLTAGE_TOLERANCE_V or volts <= self.voltages[0]:
            return [int(np.argmin(gaps))]
        if volts >= self.voltages[-1]:
            return [len(self.voltages) - 1]
        above = int(np.searchsorted(self.voltages, volts))
        return [above - 1, above]

    def smallest_command(self, sign: float = 1.0, volts: float | None = None) -> float | None:
        """The smallest |command| on the forward (sign > 0) or reverse side at which the
        calibrations at ``volts`` (or its neighbouring voltages) measured thrust, beyond
        their last reading of none (None: no such command on that side)."""
        v = self.reference_voltage if volts is None else float(volts)
        smallest = []
        for c in (self.curves[i] for i in self._bracket(v)):
            lo, hi = c.dead_band_edges()
            u = c.commands[c.commands > hi] if sign > 0 else c.commands[c.commands < lo]
            live = np.abs(u[np.sign(c.measured()[np.isin(c.commands, u)]) == np.sign(sign)])
            if live.size == 0:
                return None
            smallest.append(float(live.min()))
        return max(smallest)

    def min_force(self, volts: float | None, sign: float = 1.0) -> float | None:
        """The smallest calibrated non-zero thrust on that side at ``volts``, N (signed;
        None when that side was not calibrated)."""
        u = self.smallest_command(sign, volts)
        return None if u is None else float(self.force(math.copysign(u, sign), volts))

    def command_for_force(self, force: float, volts: float | None = None) -> ThrustEstimate:
        """The command giving ``force`` N at ``volts`` ± σ (σ of the force through the local
        slope). Raises ``ValueError`` naming the largest force deliverable at that voltage,
        or the smallest calibrated one for a non-zero force below it."""
        v = self.reference_voltage if volts is None else float(volts)
        if force == 0:
            return ThrustEstimate(0.0, 0.0, self.voltage_law(v))
        floor = self.min_force(v, math.copysign(1.0, force))
        if floor is not None and abs(force) < abs(floor):
            side = "forward" if force > 0 else "reverse"
            u = self.smallest_command(math.copysign(1.0, force), v)
            raise ValueError(
                f"force: got {force:g} N, allowed: at least {abs(floor):.4g} N {side} at {v:g} V "
                f"(the smallest calibrated thrust, command {u:g}; below it the curve is "
                "extrapolated into the dead band — calibrate smaller commands) or 0"
            )
        reach = self.max_force(v, math.copysign(1.0, force))
        if abs(force) > abs(reach):
            side = "forward" if force > 0 else "reverse"
            raise ValueError(
                f"force: got {force:g} N, allowed: up to {reach:.4g} N {side} at {v:g} V "
                "(full command; the thrusters saturate there)"
            )
        lo, hi = self.command_range
        end = hi if force > 0 else lo

        def miss(u: float) -> float:
            return float(self.force(u, v)) - force

        a, b = sorted((0.0, end))
        from scipy.optimize import brentq

        u = float(brentq(miss, a, b, xtol=1e-9))
        step = 1e-3 * (hi - lo)
        slope = abs(float(self.force(u + step, v) - self.force(u - step, v))) / (2 * step)
        sigma_f = self.estimate(u, v).std
        return ThrustEstimate(u, sigma_f / slope if slope > 0 else math.inf, self.voltage_law(v))

    def to_json(self) -> dict:
        return {
            "voltages_v": [float(v) for v in self.voltages],
            "identified": self.identified,
            "interpolation": (
                "assumed power law"
                if not self.identified
                else ("linear in V" if len(self.curves) == 2 else "monotone cubic (PCHIP) in V")
            ),
            "interpolation_error_of_full_thrust": self.interpolation_error,
            "assumed_exponent": {
                "value": self.assumed_exponent[0],
                "std": self.assumed_exponent[1],
            },
            "command_range": list(self.command_range),
            "held_out": self.held_out,
            "curves": [
                {"voltage_v": float(v), "fit": c.curve.to_json()}
                for v, c in zip(self.voltages, self.curves, strict=True)
            ],
        }


def _group_by_voltage(table: list[dict]) -> dict[float, list[dict]]:
    groups: dict[float, list[dict]] = {}
    for row in table:
        volts = row.get("supply_voltage_v")
        key = math.nan if volts is None else float(volts)
        match = next(
            (k for k in groups if not math.isnan(k) and abs(k - key) <= VOLTAGE_TOLERANCE_V), key
        )
        groups.setdefault(match, []).append(row)
    nan_keys = [k for k in groups if math.isnan(k)]
    if nan_keys and len(groups) > len(nan_keys):
        raise ValueError(
            "supply_voltage_v: some rows have a voltage and some not; give all or none"
        )
    merged: dict[float, list[dict]] = {}
    for k, rows in groups.items():
        merged.setdefault(math.nan if math.isnan(k) else k, []).extend(rows)
    return merged


def _curve(rows: list[dict]) -> CalibratedThrust:
    u = [float(r["command"]) for r in rows]
    f = [float(r["thrust_per_thruster_n"]) for r in rows]
    return CalibratedThrust.from_table(fit_thrust_curve(u, f), rows)


def _build(groups: dict[float, list[dict]], nominal_v: float | None) -> ThrustLaw:
    keys = sorted(groups)
    if len(keys) == 1 and math.isnan(keys[0]):
        if nominal_v is None:
            raise ValueError(
                "supply_voltage_v: the calibration recorded no supply voltage; give the "
                "voltage it was made at"
            )
        keys_v = [float(nominal_v)]
    else:
        keys_v = [float(k) for k in keys]
    curves = tuple(_curve(groups[k]) for k in keys)
    return ThrustLaw(np.array(keys_v), curves)


def identify_thrust_law(table: list[dict], nominal_v: float | None = None) -> ThrustLaw:
    """The thrust law of a calibration table (rows ``command``, ``thrust_per_thruster_n``,
    ``supply_voltage_v``). Rows within ``VOLTAGE_TOLERANCE_V`` of each other are one
    voltage; a table without voltages needs ``nominal_v``. With ≥ 3 voltages the
    interpolation error is measured by leaving each interior voltage out."""
    groups = _group_by_voltage(table)
    law = _build(groups, nominal_v)
    keys = sorted(groups)
    if len(keys) < 3:
        return law
    errors: dict[str, float] = {}
    full = law._full()
    lo, hi = law.command_range
    grid = np.linspace(lo, hi, 81)
    for k in keys[1:-1]:
        rest = _build({kk: groups[kk] for kk in keys if kk != k}, None)
        truth = law.curves[keys.index(k)].force(grid)
        errors[f"{k:g}"] = float(np.sqrt(np.mean((rest.force(grid, k) - truth) ** 2)) / full)
    rms = float(np.sqrt(np.mean(np.square(list(errors.values())))))
    return ThrustLaw(law.voltages, law.curves, rms, held_out=errors)
