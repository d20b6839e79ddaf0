"""Thrust calibration curve: per-side power law with dead band, asymmetry and hysteresis.

    u_e = u − h·s/2            (s = +1 while the command rises, −1 while it falls, 0 unknown)
    F = +k_f·(u_e − d_f)^p_f    for u_e > d_f        (forward side)
    F = −k_r·(−u_e − d_r)^p_r   for u_e < −d_r       (reverse side)
    F = 0                       inside the dead band −d_r ≤ u_e ≤ d_f
p < 1 is a concave (saturating) curve, where a plain F = c·|u|·u leaves a bowed residual.
Commands are in the thruster's command units (e.g. −1 … 1); forces in N.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from estimation.thrust import MIN_POINTS_PER_SIDE

#: Physical bounds of the parameters (gain_f, dead_f, exp_f, gain_r, dead_r, exp_r,
#: hysteresis): gains > 0, dead bands ≥ 0, exponents 0.2 … 3. The fit narrows the dead
#: bands and the hysteresis to the commands' span; parameter draws stay inside these.
PARAMETER_LOWER = np.array([1e-9, 0.0, 0.2, 1e-9, 0.0, 0.2, -np.inf])
PARAMETER_UPPER = np.array([np.inf, np.inf, 3.0, np.inf, np.inf, 3.0, np.inf])

PARAMS: tuple[str, ...] = (
    "forward_gain",
    "forward_dead_band",
    "forward_exponent",
    "reverse_gain",
    "reverse_dead_band",
    "reverse_exponent",
    "hysteresis",
)
#: Unit of each parameter. Commands are fractions of full scale, so a gain is the thrust one
#: full command unit beyond the dead band (N); exponents are dimensionless ("1").
PARAM_UNITS: dict[str, str] = {
    "forward_gain": "N",
    "forward_dead_band": "command",
    "forward_exponent": "1",
    "reverse_gain": "N",
    "reverse_dead_band": "command",
    "reverse_exponent": "1",
    "hysteresis": "command",
}


def _model(params: np.ndarray, command: np.ndarray, direction: np.ndarray) -> np.ndarray:
    k_f, d_f, p_f, k_r, d_r, p_r, hyst = params
    u = command - 0.5 * hyst * direction
    fwd = np.clip(u - d_f, 0.0, None)
    rev = np.clip(-u - d_r, 0.0, None)
    return k_f * fwd**p_f - k_r * rev**p_r


@dataclass(frozen=True)
class ThrustCurve:
    """A fitted thrust curve: values and σ in PARAMS order, plus fit quality."""

    values: np.ndarray
    std: np.ndarray
    correlation: np.ndarray
    rmse_n: float
    command_min: float
    command_max: float

    def parameter(self, name: str) -> float:
        """Fitted value of one parameter (see PARAMS)."""
        return float(self.values[PARAMS.index(name)])

    def force(self, command: np.ndarray | float, direction: np.ndarray | float = 0.0):
        """Thrust in N for a command (direction +1 rising command, −1 falling, 0 mid-loop)."""
        u = np.asarray(command, dtype=float)
        s = np.broadcast_to(np.asarray(direction, dtype=float), u.shape)
        return _model(self.values, u, s)

    def command_for_force(self, force: np.ndarray | float, direction: float = 0.0):
        """Inverse map: the command giving ``force`` N (0 N → 0). Raises when out of reach."""
        k_f, d_f, p_f, k_r, d_r, p_r, hyst = self.values
        f = np.asarray(force, dtype=float)
        fwd = d_f + (np.clip(f, 0.0, None) / k_f) ** (1.0 / p_f)
        rev = -(d_r + (np.clip(-f, 0.0, None) / k_r) ** (1.0 / p_r))
        u = np.where(f > 0, fwd, np.where(f < 0, rev, 0.0)) + 0.5 * hyst * direction
        u = np.where(f == 0, 0.0, u)
        lo, hi = self.command_min, self.command_max
        if np.any((u < lo - 1e-9) | (u > hi + 1e-9)):
            worst = float(f.flat[np.argmax(np.abs(u).ravel())])
            reach = (float(self.force(lo)), float(self.force(hi)))
            raise ValueError(
                f"force: got {worst:g} N, allowed: {reach[0]:.4g} … {reach[1]:.4g} N "
                f"(commands {lo:g} … {hi:g})"
            )
        return u

    @classmethod
    def from_json(cls, data: dict) -> ThrustCurve:
        """Rebuild a stored curve from ``to_json()`` output (results stored before the
        correlation was kept get the identity)."""
        params = data["parameters"]
        values = np.array([params[n]["value"] for n in PARAMS], dtype=float)
        std = np.array([params[n]["std"] for n in PARAMS], dtype=float)
        lo, hi = data["command_range"]
        corr = np.eye(len(PARAMS))
        stored = data.get("correlation")
        if stored is not None:
            names = list(stored["names"])
            order = [names.index(n) for n in PARAMS]
            corr = np.array(stored["matrix"], dtype=float)[np.ix_(order, order)]
        return cls(values, std, corr, float(data["rmse_n"]), float(lo), float(hi))

    def to_json(self) -> dict:
        """{parameters: {name: {value, std, unit}}, correlation: {names, matrix}, rmse_n,
        command_range}."""
        return {
            "parameters": {
                n: {"value": float(v), "std": float(s), "unit": PARAM_UNITS[n]}
                for n, v, s in zip(PARAMS, self.values, self.std, strict=True)
            },
            "correlation": {
                "names": list(PARAMS),
                "matrix": [[float(x) for x in row] for row in np.asarray(self.correlation)],
            },
            "rmse_n": self.rmse_n,
            "command_range": [self.command_min, self.command_max],
        }


def _side_guess(u: np.ndarray, f: np.ndarray) -> tuple[float, float, float]:
    if u.size == 0 or np.max(f) <= 0:
        return 1.0, 0.05, 1.0
    small = u[f < 0.05 * f.max()]
    dead = float(small.max()) if small.size else 0.0
    return float(f.max() / max(u.max() - dead, 1e-3)), min(dead, 0.9 * u.max()), 1.0


def sweep_signs(command: np.ndarray, directions: Sequence[object] | np.ndarray) -> np.ndarray:
    """Signed sweep direction s per point from numbers (+1 command rising, −1 falling, 0) or
    from the calibration table's words ("up"/"down"/"hold", meaning |command| rising/falling)."""
    u = np.asarray(command, dtype=float)
    values = list(directions)
    if len(values) != u.size:
        raise ValueError(
            f"directions: got {len(values)} values for {u.size} commands, allowed: one per command"
        )
    words = {"up": 1.0, "down": -1.0, "hold": 0.0}
    if all(isinstance(v, str) for v in values):
        unknown = sorted({v for v in values if v not in words})
        if unknown:
            raise ValueError(f"directions: got {unknown}, allowed: 'up', 'down', 'hold'")
        return np.array([words[v] for v in values]) * np.sign(u)
    return np.asarray(values, dtype=float)


def fit_thrust_curve(
    command: Sequence[float] | np.ndarray,
    force: Sequence[float] | np.ndarray,
    directions: Sequence[object] | np.ndarray | None = None,
) -> ThrustCurve:
    """Fit the per-side curve to static thrust points (command, force N, sweep direction).

    ``directions``: signed numbers (+1 rising command, −1 falling, 0 unknown) or the words
    "up"/"down"/"hold" (|command| rising/falling), see ``sweep_signs``; None = no hysteresis.
    """
    u = np.asarray(command, dtype=float)
    f = np.asarray(force, dtype=float)
    if u.shape != f.shape or u.ndim != 1:
        raise ValueError(f"force: got shape {f.shape} vs command {u.shape}, allowed: same 1-D")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(f))):
        raise ValueError("command/force: got NaN/inf, allowed: finite values")
    forward, reverse = np.count_nonzero(u > 0), np.count_nonzero(u < 0)
    if min(forward, reverse) < MIN_POINTS_PER_SIDE:
        raise ValueError(
            f"command: got {forward} forward and {reverse} reverse points, "
            f"allowed: at least {MIN_POINTS_PER_SIDE} on each side"
        )
    s = np.zeros_like(u) if directions is None else sweep_signs(u, directions)
    kf, df, pf = _side_guess(u[u > 0], f[u > 0])
    kr, dr, pr = _side_guess(-u[u < 0], -f[u < 0])
    p0 = np.array([kf, df, pf, kr, dr, pr, 0.0])
    span = float(np.max(np.abs(u)))
    # dead bands and hysteresis within the commands' span
    lower = np.maximum(PARAMETER_LOWER, [-np.inf] * 6 + [-span])
    upper = np.minimum(PARAMETER_UPPER, [np.inf, span, np.inf, np.inf, span, np.inf, span])
    if not np.any(s):
        lower[6], upper[6] = -1e-12, 1e-12
    from scipy.optimize import least_squares  # the service's process has no use for it

    sol = least_squares(
        lambda p: _model(p, u, s) - f,
        np.clip(p0, lower, upper),
        bounds=(lower, upper),
        x_scale="jac",
    )
    res = sol.fun
    dof = max(res.size - 7, 1)
    cov = float(res @ res) / dof * np.linalg.pinv(sol.jac.T @ sol.jac)
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    denom = np.outer(std, std)
    corr = np.divide(cov, denom, out=np.eye(7), where=denom > 0)
    return ThrustCurve(
        sol.x, std, corr, float(np.sqrt(np.mean(res**2))), float(u.min()), float(u.max())
    )


@dataclass(frozen=True)
class CalibratedThrust:
    """The fitted curve corrected by its residuals at the calibrated commands (mean of the
    up and down sweeps, interpolated linearly between commands, zero at command 0 and in
    the measured dead band): exact where the thrust was measured, the curve's shape in
    between."""

    curve: ThrustCurve
    commands: np.ndarray
    residuals: np.ndarray
    #: Mean supply voltage while each command was measured, V (NaN: not recorded).
    voltages: np.ndarray | None = None

    @classmethod
    def from_table(cls, curve: ThrustCurve, table: list[dict]) -> CalibratedThrust:
        """Residuals of ``curve`` at each calibrated command of the calibration table, and
        the supply voltage each command was measured at."""
        by_command: dict[float, list[float]] = {0.0: []}
        volts: dict[float, list[float]] = {}
        for row in table:
            u = float(row["command"])
            by_command.setdefault(u, []).append(float(row["thrust_per_thruster_n"]))
            if row.get("supply_voltage_v") is not None:
                volts.setdefault(u, []).append(float(row["supply_voltage_v"]))
        commands = np.array(sorted(by_command))
        residuals = np.array(
            [
                float(np.mean(by_command[u]) - curve.force(u)) if u != 0 and by_command[u] else 0.0
                for u in commands
            ]
        )
        voltages = np.array([np.mean(volts[u]) if u in volts else np.nan for u in commands])
        return cls(curve, commands, residuals, voltages)

    def with_curve(self, curve: ThrustCurve) -> CalibratedThrust:
        """The same residual correction on another (drawn) curve."""
        return CalibratedThrust(curve, self.commands, self.residuals, self.voltages)

    def supply_factor(
        self, command: np.ndarray, volts: np.ndarray, exponent: float
    ) -> np.ndarray | float:
        """(V / V_cal(command))^exponent: the thrust at supply ``volts`` relative to the
        calibration's at that command (V_cal interpolated between calibrated commands).
        1 when the calibration recorded no voltage or ``exponent`` is 0."""
        known = self.voltages is not None and np.isfinite(self.voltages)
        if not exponent or not np.any(known):
            return 1.0
        assert self.voltages is not None
        v_cal = np.interp(command, self.commands[known], self.voltages[known])
        return (np.asarray(volts, dtype=float) / v_cal) ** exponent

    def measured(self) -> np.ndarray:
        """The mean thrust measured at each calibrated command, N (0 at command 0)."""
        return np.asarray(self.curve.force(self.commands), dtype=float) + self.residuals

    def dead_band_edges(self) -> tuple[float, float]:
        """The outermost calibrated commands (reverse ≤ 0 ≤ forward) that measured no
        thrust on their side: the dead band as measured."""
        m = self.measured()
        c = self.commands
        fwd = c[(c >= 0) & (m <= 0)]
        rev = c[(c <= 0) & (m >= 0)]
        return float(rev.min()) if rev.size else 0.0, float(fwd.max()) if fwd.size else 0.0

    def force(self, command: np.ndarray | float) -> np.ndarray:
        """Thrust of one thruster, N. Where the fitted curve is in its dead band but the
        calibration measured thrust (a fitted dead band wider than the measured one, as a
        curve bent by saturation has), the measured thrusts interpolated linearly."""
        base = self.curve.force(command)
        u = np.asarray(command, dtype=float)
        lo, hi = self.dead_band_edges()
        live = (base == 0) & ((u > hi) | (u < lo))
        if not np.any(live):
            return base + np.where(base != 0, np.interp(u, self.commands, self.residuals), 0.0)
        between = np.interp(u, self.commands, self.measured())
        between = np.where(u > 0, np.clip(between, 0.0, None), np.clip(between, None, 0.0))
        corrected = base + np.interp(u, self.commands, self.residuals)
        return np.where(base != 0, corrected, np.where(live, between, 0.0))

    def command_for_force(self, force: float) -> float:
        """The command whose corrected thrust is ``force`` N: the curve's inverse (which
        raises when out of reach), refined on the corrected curve between 0 and the end
        of the calibrated commands on that side."""
        guess = float(self.curve.command_for_force(force))
        if force == 0:
            return 0.0
        end = self.curve.command_max if force > 0 else self.curve.command_min
        lo, hi = sorted((0.5 * guess, end))

        def miss(u: float) -> float:
            return float(self.force(u)) - force

        if miss(lo) * miss(hi) > 0:  # the correction moves the force out of reach there
            return guess
        from scipy.optimize import brentq

        return float(brentq(miss, lo, hi, xtol=1e-9))
