"""The estimator's advice ("add a reverse tow", "add a run at a clearly different force"),
drawn from the planner's envelope so it is never stale nor beyond the rig.

Without an envelope (a notebook on imported data) the advice names no load beyond what the
runs used: "at most your rig's limit". With one (``api.core.rig_envelope`` from the rig
file), every load it names is a test :meth:`RigEnvelope.candidates` offers.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.data.driven_axes import driven_axis
from estimation.design.planning_envelope import Candidate, RigEnvelope


def separating_load(
    axis: str,
    used: Sequence[float],
    envelope: RigEnvelope | None,
    drive: str = "weight",
) -> Candidate | None:
    """The forward load (driven by ``drive``: weight | thrusters) the rig offers furthest
    (in ratio) from every ``used`` |load|; None without an envelope or when it offers none
    clearly different (ratio < 1.5)."""
    if envelope is None or not used:
        return None
    offered = [c for c in envelope.candidates(axis) if c.load > 0 and c.drive == drive]
    if not offered:
        return None
    mags = np.abs(np.asarray(used, dtype=float))

    def gap(c: Candidate) -> float:
        return float(np.min(np.abs(np.log(c.load / mags))))

    best = max(offered, key=gap)
    return best if gap(best) >= np.log(1.5) else None


def different_force_advice(
    axis: str, drives: Sequence[float], rho: float, envelope: RigEnvelope | None
) -> str:
    """K_L and K_Q poorly separated: the run at a clearly different load, within the rig."""
    words = driven_axis(axis)
    unit, what = words.load_unit, words.load_name
    shown = ", ".join(f"{d:.3g}" for d in drives)
    head = (
        f"K_L and K_Q are not separable from one {what} (ρ = {rho:.3f})"
        if len(drives) == 1
        else f"K_L and K_Q are poorly separated (ρ = {rho:.3f}) by {what}s {shown} {unit}"
    )
    test = separating_load(axis, drives, envelope)
    if test is not None:
        return f"{head}: add a run at a clearly different {what}: run `{test.command}`"
    if envelope is not None:
        return (
            f"{head}: the rig offers no {what} clearly different from these within its "
            f"limits; a free-decay run or a longer record would separate them"
        )
    if len(drives) == 1:
        return (
            f"{head}: add a run at a clearly different {what} (e.g. 4× the current one, "
            f"{4 * drives[0]:.3g} {unit}, if within your rig's limits)"
        )
    return (
        f"{head}: add a run well outside that range (e.g. {0.25 * min(drives):.3g} {unit}, "
        f"or {2 * max(drives):.3g} {unit} if within your rig's limits)"
    )


def both_ways(drives: Sequence[float]) -> bool:
    """Whether the runs already moved both ways."""
    return len({np.sign(d) for d in drives if d != 0}) > 1


def reverse_advice(
    axis: str, drives: Sequence[float], envelope: RigEnvelope | None, command: str | None
) -> str:
    """Friction vs bias ambiguous: the reverse run if none was recorded (``command``: the
    one to run), else what the reverse runs lack; never a reverse run the rig cannot do."""
    kind = driven_axis(axis).kind
    head = "coulomb_friction and constant_bias are not separated"
    if both_ways(drives):
        back = [abs(d) for d in drives if d < 0]
        test = separating_load(axis, back, envelope)
        run = f": run `{Candidate(test.axis, -test.load).command}`" if test else ""
        return (
            f"{head} although the runs already go both ways: a reverse {kind} at a clearly "
            f"different load (or a longer one), or a free-decay run, would{run}"
        )
    env = envelope.driven(axis) if envelope is not None else None
    if env is not None and env.reverse_travel is None:
        return f"{head} (every run moves one way, the rig has no reverse {kind}): add a free decay"
    run = f": run `{command}`" if command else ""
    return (
        f"{head}: they are collinear when every run moves the same way: add a reverse "
        f"{kind} (opposite load) or a free-decay run{run}"
    )


def separating_hint(hint: str, drives: Sequence[float]) -> str:
    """An effect's "separated by" text (``estimation.motion.terms``), unless it asks for a
    reverse run the set already has: then a clearly different load or a free decay."""
    if both_ways(drives) and "reverse" in hint:
        return (
            "a run at a clearly different load, or a free-decay run (the runs already go both ways)"
        )
    return hint
