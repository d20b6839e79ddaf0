"""Stick-slip (Coulomb + break-away) friction for the plant's fixed-step integrators."""

from __future__ import annotations


def sign(x: float) -> float:
    """+1, −1 or 0."""
    return 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)


def stick_slip_step(
    v: float, drive: float, force: float, mass: float, coulomb: float, static: float, dt: float
) -> float:
    """One semi-implicit velocity step with stick-slip friction.

    ``drive`` is what tries to move a body at rest (weights, thrust, springs: no damping),
    ``force`` the total without friction; ``static`` 0 means break-away at ``coulomb``.
    Works the same for a force (N, kg, m/s) and a torque (N·m, kg·m², rad/s).
    """
    if coulomb == 0 and static == 0:
        return v + force / mass * dt
    if v == 0.0:
        if abs(drive) <= (static or coulomb):
            return 0.0  # stuck: friction balances the drive
        force -= coulomb * sign(drive)
        return v + force / mass * dt
    v_new = v + (force - coulomb * sign(v)) / mass * dt
    return 0.0 if v_new * v < 0 else v_new  # friction stops it; re-check break-away
