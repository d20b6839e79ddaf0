"""What a result may tell its user to do, by the kind of record it came from: one table, so
a warning never names a cause the record cannot have nor advice only another kind can take.

A tow or a spin recorded on this rig can be run again in reverse, repeated by a sequence and
given tolerances in its rig file; a free decay or a pendulum swing has no drive to reverse;
runs imported without a rig file (``import``) have no rig file to edit and no sequence to
repeat: their advice names the import's options instead (README, ``rig import``).
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class KindAdvice:
    """The words one kind of record takes. ``reverse_run``: the run that reverses the drive
    (None: the record has no drive to reverse); ``dry_friction``: where a dry friction can act
    on such a record; ``declare_tolerances``: how its Type B inputs are declared;
    ``repeat_runs``: how the same condition is recorded again."""

    kind: str
    reverse_run: str | None
    dry_friction: str
    declare_tolerances: str
    repeat_runs: str


#: Every kind of record a result can come from (``import``: runs without a rig file).
ADVICE: dict[str, KindAdvice] = {
    a.kind: a
    for a in (
        KindAdvice(
            "tow",
            "a reverse tow (opposite force)",
            "the carriage's rails or the tow line's pulleys",
            "add [tolerances] to the rig file, README 'Declaring tolerances'",
            "set `repeats` ≥ 3 in the sequence",
        ),
        KindAdvice(
            "spin",
            "a reverse spin (opposite torque)",
            "the turntable's bearing or the cord's drum",
            "add [tolerances] to the rig file, README 'Declaring tolerances'",
            "set `repeats` ≥ 3 in the sequence",
        ),
        KindAdvice(
            "decay",
            None,
            "a guide, mooring or bearing the body touches",
            "declare the half-widths at import: --stiffness-tolerance, --known-inertia-tolerance",
            "import ≥ 3 decays of the same condition and estimate them together",
        ),
        KindAdvice(
            "pendulum",
            None,
            "the pivot",
            "add [tolerances] to the rig file, README 'Declaring tolerances'",
            "record ≥ 3 decays from the same release angle and estimate them together",
        ),
        KindAdvice(
            "import",
            "an opposite drive (the body moved the other way)",
            "a guide, carriage or bearing the body touches; none acts on a body free in the fluid",
            "import the runs again with --rig FILE whose [tolerances] declare them, README "
            "'Declaring tolerances'",
            "import ≥ 3 records of the same condition and estimate them together",
        ),
    )
}


def advice_for(kind: str) -> KindAdvice:
    """The advice of ``kind`` (tow, spin, decay, pendulum, import)."""
    if kind not in ADVICE:
        raise ValueError(f"kind: got {kind!r}, allowed: {', '.join(ADVICE)}")
    return ADVICE[kind]
