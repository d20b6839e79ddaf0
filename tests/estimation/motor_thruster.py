"""A thruster whose thrust is *not* a power law of the supply voltage: a DC motor with
back-EMF and a soft current limit turning a propeller (steady state), behind an ESC with
a dead band. At a fixed command the local exponent d ln F / d ln V runs from ≈ 1.5 at
part command down to ≈ 0 where the current limit holds the thrust at full command.

``calibration_csv`` writes its bollard table as Excel would in a decimal-comma locale:
UTF-8 with a byte-order mark, ``;`` separators, decimal commas, thrust in kgf, command in
PWM µs (1500 neutral, ±400 full), with noise.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

KGF = 9.80665
#: Winding resistance Ω, motor constant V·s/rad (= N·m/A), propeller torque and thrust
#: coefficients (N·m·s², N·s²), current limit A, its softness, ESC dead band µs,
#: reverse thrust relative to forward.
R, K, KQ, KT = 0.12, 0.0065, 2.2e-7, 6.6e-5
I_MAX, SOFTNESS, DEAD_US, REVERSE = 40.0, 6.0, 25.0, 0.8
PWM = np.arange(1100, 1901, 25)


def thrust_n(pwm: float, volts: float) -> float:
    """Steady bollard thrust, N: duty d beyond the dead band puts d·V on the motor; the
    motor torque K·I (I = (d·V − K·ω)/R, softly limited to I_MAX) balances KQ·ω²."""
    u = (pwm - 1500.0) / 400.0
    duty = max(abs(u) - DEAD_US / 400, 0.0) / (1 - DEAD_US / 400)
    if duty == 0:
        return 0.0
    v_motor = duty * volts

    def torque_gap(w: float) -> float:
        current = (v_motor - K * w) / R
        limited = current / (1 + (current / I_MAX) ** SOFTNESS) ** (1 / SOFTNESS)
        return K * limited - KQ * w * w

    w = brentq(torque_gap, 0.0, v_motor / K)
    return math.copysign(KT * w * w * (REVERSE if u < 0 else 1.0), u)


def full_thrust_n(voltages) -> float:
    return max(abs(thrust_n(p, v)) for v in voltages for p in (PWM[0], PWM[-1]))


def calibration_csv(voltages, *, noise_kgf: float = 0.03, seed: int = 7) -> bytes:
    """The bollard table at ``voltages``: header ``PWM (µs);Spannung (V);Schub (kgf)``."""
    rng = np.random.default_rng(seed)
    lines = ["PWM (µs);Spannung (V);Schub (kgf)"]
    for volts in voltages:
        for pwm in PWM:
            kgf = thrust_n(pwm, volts) / KGF + rng.normal(0.0, noise_kgf)
            lines.append(f"{pwm};{volts:.1f};{kgf:.3f}".replace(".", ","))
    return ("\ufeff" + "\r\n".join(lines) + "\r\n").encode("utf-8")
