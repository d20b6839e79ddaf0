"""The effects a tow or spin can find: entries of the one term library
(``estimation.motion.terms``), where each carries its own physics (regressor, derivatives,
bounds, scale, start value, what separates it, report text).

Base model (one axis, SI units):
    (M + M_drive) v̇ + K_L·v + K_Q·|v|·v = τ(t)
where M is the vehicle's inertia (m + m_a or I) and M_drive the declared drive-train and
hung-weight inertia; ``linear_damping`` and ``quadratic_damping`` are library entries too.
Each effect adds one entry's term to it.
"""

from __future__ import annotations

from estimation.motion.terms import LIBRARY, STANDARD_GRAVITY, Term

#: The library entries a tow or spin searches, in search order (common causes first).
AXIS_EFFECTS: tuple[str, ...] = (
    "coulomb_friction",
    "constant_bias",
    "drive_inertia",
    "restoring_spring",
    "cubic_drag",
    "release_delay",
)
Effect = Term
EFFECTS: dict[str, Term] = {name: LIBRARY[name] for name in AXIS_EFFECTS}

__all__ = ["EFFECTS", "STANDARD_GRAVITY", "Effect", "effect_names"]


def effect_names() -> tuple[str, ...]:
    """Names of all effects in the library, in search order."""
    return tuple(EFFECTS)
