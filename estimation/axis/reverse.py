"""The reverse test that separates dry friction from a constant bias, as a runnable command.

On runs that all move one way, ``−F_c·sign(v)`` and ``+b`` are the same constant force:
the estimator reports them ambiguous. A run with the opposite drive flips the friction but
not the bias. :func:`suggest_reverse_test` names that run: its axis, its signed drive and the
``rig`` command (and the ``POST /api/jobs/<route>`` body) that records it, in the axis's
words (``estimation.data.driven_axes``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from estimation.data.driven_axes import DrivenAxis, driven_axis
from estimation.data.run_arrays import RunData

#: The pair a reverse run separates.
FRICTION_AND_BIAS = frozenset({"coulomb_friction", "constant_bias"})


@dataclass(frozen=True)
class ReverseTest:
    """A run on ``axis`` with the drive opposite to every run estimated.

    ``drive``: N (surge) or N·m (yaw), signed; ``thrusters``: driven by the thrusters (the
    runs were), else by a hung weight. Its kind, field and command are the axis's words
    (``estimation.data.driven_axes``)."""

    axis: str
    drive: float
    thrusters: bool

    @property
    def words(self) -> DrivenAxis:
        return driven_axis(self.axis)

    @property
    def kind(self) -> str:
        return self.words.kind

    @property
    def field(self) -> str:
        return self.words.load_field

    @property
    def command(self) -> str:
        """``rig tow --force -83.3`` (``--thrusters`` when thruster-driven)."""
        return self.words.command_line(self.drive, self.drive_kind)

    def request(self) -> dict[str, Any]:
        """The body of ``POST /api/jobs/<route>`` that starts it."""
        return self.words.request(self.drive, self.drive_kind)

    @property
    def drive_kind(self) -> str:
        return "thrusters" if self.thrusters else "weight"

    def to_json(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "command": self.command,
            "route": f"/api/jobs/{self.words.route}",
            "request": self.request(),
        }


def suggest_reverse_test(
    axis: str, runs: Sequence[RunData], ambiguous: Sequence[Sequence[str]]
) -> ReverseTest | None:
    """The reverse run to record when friction and bias are ambiguous and every run moved
    one way; None otherwise (already separated, or runs both ways)."""
    if not any(set(group) >= FRICTION_AND_BIAS for group in ambiguous):
        return None
    return opposite_run(axis, runs)


def opposite_run(axis: str, runs: Sequence[RunData]) -> ReverseTest | None:
    """The run with the drive opposite to every run's (None when they already go both ways).

    Weight-driven: the largest drive used, turned round (the fastest run shows the friction
    best). Thruster-driven: the smallest, turned round (thrusters push less in reverse)."""
    if not runs:
        return None
    drives = [float(np.mean(r.drive_at_samples()[np.asarray(r.t) > r.t_release])) for r in runs]
    signs = {np.sign(d) for d in drives if d != 0}
    if len(signs) != 1:
        return None
    thrusters = all(r.drive_law is not None for r in runs)
    size = min(abs(d) for d in drives) if thrusters else max(abs(d) for d in drives)
    return ReverseTest(axis, -signs.pop() * size, thrusters)
