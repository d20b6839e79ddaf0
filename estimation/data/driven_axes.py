"""The rig's words for each axis a hung weight or the thrusters drive, as the estimator
proposes runs in them: the run kind that moves the axis, the ``rig`` command and
``POST /api/jobs/<route>`` that start it, and the request field holding its signed load
with its name, unit and command-line option.

The one place in ``estimation`` that names a run kind (``tests/test_kind_branches.py``):
a suggested run (the reverse test, the planner's candidates, the advice) reads these
words, so no module branches on ``"tow"``. ``estimation`` imports nothing of the rig
(``tests/test_layout.py``), so this table restates the registry's words
(``daq.procedures.kinds``, ``daq.vocabulary.AXES``) from the estimator's side;
``tests/estimation/data/test_driven_axes.py`` fails when the two disagree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class DrivenAxis:
    """One driven axis in the rig's words (the surge's: a ``tow``, ``force_n`` in N,
    ``--force``)."""

    #: The run kind that moves it: "tow".
    kind: str
    #: ``rig <command>`` and ``POST /api/jobs/<route>`` that start such a run.
    command: str
    route: str
    #: The request field holding the signed load, what the load is, its unit and its
    #: ``rig`` option: "force_n", "force", "N", "--force".
    load_field: str
    load_name: str
    load_unit: str
    load_option: str
    #: The request field that stops the run short of the rig's full travel, its unit and
    #: its ``rig`` option: "max_distance_m", "m", "--max-distance".
    travel_field: str
    travel_unit: str
    travel_option: str

    def command_line(self, load: float, drive: str = "weight", travel: float | None = None) -> str:
        """``rig tow --force -83.3`` (``--thrusters`` when ``drive`` is the thrusters;
        ``--max-distance 2.5`` when ``travel`` stops it short of the rig's full travel)."""
        thrusters = " --thrusters" if drive == "thrusters" else ""
        short = "" if travel is None else f" {self.travel_option} {travel:.4g}"
        return f"rig {self.command} {self.load_option} {load:.4g}{thrusters}{short}"

    def request(
        self, load: float, drive: str = "weight", travel: float | None = None
    ) -> dict[str, Any]:
        """The body of ``POST /api/jobs/<route>`` that starts it."""
        short = {} if travel is None else {self.travel_field: float(f"{travel:.4g}")}
        return {self.load_field: float(f"{load:.4g}"), "drive": drive} | short


#: Per axis (``RunData.axis``), its words; an axis missing is driven by nothing of the rig.
DRIVEN_AXES: dict[str, DrivenAxis] = {
    "surge": DrivenAxis("tow", "tow", "tow", "force_n", "force", "N", "--force",
                        "max_distance_m", "m", "--max-distance"),
    "yaw": DrivenAxis("spin", "spin", "spin", "torque_nm", "torque", "N·m", "--torque",
                      "max_angle_rad", "rad", "--max-angle"),
}  # fmt: skip


def driven_axis(axis: str) -> DrivenAxis:
    """The words of ``axis``; ``ValueError`` naming the driven axes for any other."""
    words = DRIVEN_AXES.get(axis)
    if words is None:
        raise ValueError(f"axis: {axis!r} is not allowed; allowed {', '.join(DRIVEN_AXES)}")
    return words
