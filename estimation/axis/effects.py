"""The effect library: physical effects the base axis model lacks, with their signatures.

Base model (one axis, SI units):
    (M + M_drive) v̇ + K_L·v + K_Q·|v|·v = τ(t)
where M is the vehicle's inertia (m + m_a or I) and M_drive the declared drive-train and
hung-weight inertia. Each effect adds one parameter to it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

STANDARD_GRAVITY = 9.80665  # m/s², scales the drive_inertia effect (k·|τ|/g)


@dataclass(frozen=True)
class Effect:
    """One candidate effect: physical name, formula, unit per axis and residual signature."""

    name: str
    formula: str
    unit_surge: str
    unit_yaw: str
    signature: str
    separated_by: str
    lower: float = -np.inf
    upper: float = np.inf
    needs_integration: bool = False

    def unit(self, axis: str) -> str:
        """Unit of the effect's parameter on ``axis``."""
        return self.unit_surge if axis == "surge" else self.unit_yaw


EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect(
            "coulomb_friction",
            "τ_f = −F_c·sign(v)",
            "N",
            "N·m",
            "constant force-domain residual that flips with the direction of motion; "
            "steady speed too low at small forces (negative K_Q if forced into the drag law)",
            "a reverse tow/spin (opposite force) or a free-decay run",
            lower=0.0,
        ),
        Effect(
            "constant_bias",
            "τ_b = b (does not flip with direction)",
            "N",
            "N·m",
            "constant force-domain residual of the same sign for both directions "
            "(current, cable tension)",
            "a reverse tow/spin (opposite force)",
        ),
        Effect(
            "drive_inertia",
            "M_app = M + k·|τ|/g (the hung weight accelerates too)",
            "kg/kg",
            "m",
            "apparent inertia that grows with the drive: transients too slow at large weights",
            "runs at clearly different weights with the hung mass declared",
            lower=0.0,
        ),
        Effect(
            "restoring_spring",
            "τ_s = −k_s·(x − x_release)",
            "N/m",
            "N·m/rad",
            "force-domain residual proportional to position; speed sags along the run",
            "a long run at small force, or a static pull at two positions",
        ),
        Effect(
            "cubic_drag",
            "τ_c = −K_C·v³",
            "N·s³/m³",
            "N·m·s³/rad³",
            "steady-speed residual that grows with v³ (largest at the highest force)",
            "a run at a clearly higher force (e.g. 1.5× the largest)",
        ),
        Effect(
            "release_delay",
            "motion starts at t_release + δ (brake lag, stiction)",
            "s",
            "s",
            "position residual at the start of every run, a time shift of the whole response",
            "a record with the brake signal sampled with the position",
            lower=-1.0,
            upper=5.0,
        ),
    )
}


def effect_names() -> tuple[str, ...]:
    """Names of all effects in the library, in search order."""
    return tuple(EFFECTS)
