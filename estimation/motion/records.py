"""A record of one degree of freedom as the equation's fit reads it, and its setup.

A record is any sampled motion x(t) of one DOF with an optional drive: a free decay
released from an offset (no drive), a forced record (drive per sample) or a constant pull.
It starts either *free* (from the state the fit gives at its first sample) or *at rest at
its release* (a tow or a spin: held at the position it rests at until ``released_at``).
Its setup says what is known (rig or body inertia, a stiffness from hydrostatics) and what
the fit identifies.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from estimation.motion.terms import DOFS, LIBRARY

#: A free decay needs this many samples (two periods of a slow record at least).
MIN_SAMPLES = 20


@dataclass(frozen=True)
class Record:
    """One record: ``t`` in s (strictly increasing), ``x`` in m or rad, ``drive`` in N or
    N·m (None: free; a scalar: constant; else one value per sample, held to the next).

    ``known_inertia``/``known_terms``: this record's known parts when they differ between
    records (None: the setup's). ``weights``: the weight w of each identified coefficient on
    this record (name → w, ``"inertia"`` included; absent: 1): θ enters the equation as θ·w,
    so θ keeps the unit its physics has where it acts (a pendulum's vehicle at lever arm l:
    inertia and linear damping weigh l², quadratic damping l³).

    ``released_at``: the release instant (s, on ``t``'s clock) of a record at rest before
    it (its samples up to it read the rest position); None: free from its first sample.
    ``drive_before``: the drive held before the first sample (None: the first sample's).
    ``hung_weight``: |τ|/g of a hung weight whose mass is not declared (kg): the weight of
    the inertia-role terms (``drive_inertia``). ``quantum``: the position's quantization
    step (m or rad; None: read off ``x``, ``record_derivatives.record_step``).
    """

    run_id: str
    t: np.ndarray
    x: np.ndarray
    drive: float | np.ndarray | None = None
    known_inertia: float | None = None
    known_terms: Mapping[str, float] | None = None
    weights: Mapping[str, float] = field(default_factory=dict)
    released_at: float | None = None
    drive_before: float | None = None
    hung_weight: float = 0.0
    quantum: float | None = None

    @property
    def free(self) -> bool:
        """Whether the record starts free (its initial state fitted), not at rest."""
        return self.released_at is None

    def weight(self, name: str) -> float:
        """The weight of the identified coefficient ``name`` on this record (default 1)."""
        return float(self.weights.get(name, 1.0))

    def drive_at_samples(self) -> np.ndarray | None:
        """The drive as one value per sample, or None for a free record."""
        if self.drive is None:
            return None
        d = np.asarray(self.drive, dtype=float)
        return np.full(np.shape(self.t), float(d)) if d.ndim == 0 else d


@dataclass(frozen=True)
class Setup:
    """What is known about the equation and what is identified.

    ``known_inertia``: the part of the inertia that is known (kg or kg·m²: the body's dry
    inertia, a pendulum's rod, a pulley); the identified ``inertia`` is the rest (the added
    inertia when the body's own is known). ``inertia``: the identified part, when known too
    (then not fitted). ``known_terms``: coefficients fixed from outside (a hydrostatic
    stiffness ρ·g·A_w, Δ·g·GM). ``terms``: the library terms identified in the base model.
    ``min_inertia``: the smallest identified inertia the body can have (0 for an added
    inertia; the dry mass when the known part excludes the body); below it is flagged.
    """

    dof: str
    known_inertia: float = 0.0
    inertia: float | None = None
    known_terms: Mapping[str, float] = field(default_factory=dict)
    terms: tuple[str, ...] = ("linear_damping", "restoring_spring")
    min_inertia: float | None = None


def known_inertia_of(record: Record, setup: Setup) -> float:
    """The known inertia on ``record`` (kg or kg·m²): its own, else the setup's."""
    own = record.known_inertia
    return float(setup.known_inertia if own is None else own)


def known_terms_of(record: Record, setup: Setup) -> Mapping[str, float]:
    """The known terms on ``record``: its own, else the setup's."""
    own = record.known_terms
    return setup.known_terms if own is None else own


def validate(records: Sequence[Record], setup: Setup) -> None:
    """ValueError naming the record, the field, the value and what is allowed."""
    if setup.dof not in DOFS:
        raise ValueError(f"dof: got {setup.dof!r}, allowed: {', '.join(DOFS)}")
    if not records:
        raise ValueError("records: got 0 records, allowed: at least 1")
    known = [n for r in records for n in known_terms_of(r, setup)]
    unknown = [n for n in (*setup.terms, *setup.known_terms, *known) if n not in LIBRARY]
    if unknown:
        raise ValueError(f"terms: got {unknown}, allowed: {', '.join(LIBRARY)}")
    for r in records:
        m = known_inertia_of(r, setup)
        if not (np.isfinite(m) and m >= 0):
            raise ValueError(f"run {r.run_id!r}: known_inertia: got {m!r}, allowed: >= 0")
        bad = {n: w for n, w in r.weights.items() if not (np.isfinite(w) and w > 0)}
        if bad or not set(r.weights) <= {"inertia", *LIBRARY}:
            raise ValueError(
                f"run {r.run_id!r}: weights: got {dict(r.weights)}, allowed: "
                "'inertia' or library terms, each finite and > 0"
            )
    if setup.inertia is not None and not setup.inertia + setup.known_inertia > 0:
        raise ValueError(f"inertia: got {setup.inertia!r}, allowed: total inertia > 0")
    ids = [r.run_id for r in records]
    if len(set(ids)) != len(ids):
        raise ValueError(f"records: run_id: got duplicates {ids}, allowed: unique ids")
    for r in records:
        t, x = np.asarray(r.t, dtype=float), np.asarray(r.x, dtype=float)
        if t.ndim != 1 or t.shape != x.shape:
            raise ValueError(
                f"run {r.run_id!r}: x: got shape {x.shape} vs t {t.shape}, "
                "allowed: 1-D, same length as t"
            )
        if t.size < MIN_SAMPLES:
            raise ValueError(
                f"run {r.run_id!r}: t: got {t.size} samples, allowed: >= {MIN_SAMPLES}"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(x))):
            raise ValueError(f"run {r.run_id!r}: t/x: got NaN/inf, allowed: finite samples")
        if np.any(np.diff(t) <= 0):
            raise ValueError(
                f"run {r.run_id!r}: t: got non-increasing, "
                "allowed: strictly increasing sample times"
            )
        d = r.drive_at_samples()
        if d is not None and (d.shape != t.shape or not np.all(np.isfinite(d))):
            raise ValueError(
                f"run {r.run_id!r}: drive: got shape {d.shape} or NaN, "
                "allowed: None, a finite scalar or one finite value per sample"
            )
    free = all(r.drive is None for r in records)
    scale_fixed = setup.inertia is not None or any(
        any(
            LIBRARY[n].x_power is not None or LIBRARY[n].role == "inertia"
            for n in known_terms_of(r, setup)
        )
        for r in records
    )
    if free and not scale_fixed:
        raise ValueError(
            "known_terms/inertia: got neither, allowed: a free decay scales every coefficient "
            "by the same factor, so one must be known: a stiffness in known_terms (e.g. "
            "{'restoring_spring': ρ·g·A_w} for heave, Δ·g·GM for roll) or the inertia"
        )
