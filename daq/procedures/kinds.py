"""The registry of run kinds: each kind is one entry, and every face looks it up.

An entry holds the kind's request model (the API body and the ``rig`` options are
derived from it), the validator that checks a request against the rig file, the
procedure that runs it, its axis words (``daq.vocabulary.AXES``), the estimation it
feeds and its labels. The HTTP routes, the CLI commands, sequences and the job runner
iterate or index ``KINDS`` instead of branching on the kind.

Adding a kind: write its procedure (a ``run_…`` coroutine) with its parameters and
validator, add its request model to ``daq.procedures.requests`` and one entry here (and,
for ``rig --help`` to list it without importing anything, one line in ``api.cli.COMMANDS``).
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, Protocol

from daq.procedures import requests
from daq.procedures.params import (
    CalibrationParameters,
    PendulumParameters,
    SpinParameters,
    TowParameters,
    calibration_parameters,
    pendulum_parameters,
    spin_parameters,
    tow_parameters,
)
from daq.vocabulary import AXES, AxisTerms, RunKind

if TYPE_CHECKING:
    from pathlib import Path

    from pydantic import BaseModel

    from daq.config import RigConfig
    from daq.procedures.recording import AbortSignal, ProgressCallback
    from daq.procedures.steps import RunOutcome
    from daq.session import RigSession

StepParameters = TowParameters | SpinParameters | CalibrationParameters | PendulumParameters


@dataclass(frozen=True)
class KindOutcome:
    """How a kind's run ended, plus what the kind adds (a calibration's table)."""

    run: RunOutcome
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return self.run.to_json() | self.extra


class Runner(Protocol):
    def __call__(
        self,
        session: RigSession,
        params: Any,
        *,
        abort: AbortSignal,
        progress: ProgressCallback,
    ) -> Awaitable[KindOutcome]: ...


@dataclass(frozen=True)
class KindSpec:
    """One run kind, everything the faces need to offer it."""

    kind: RunKind
    #: What the operator reads: "tow test".
    label: str
    #: One line for ``rig <command> --help``.
    help: str
    #: The request model (``daq.procedures.requests``): API body and CLI options.
    request: type[BaseModel]
    #: Check a request (dict of given fields) against the rig → frozen parameters.
    validate: Callable[[dict[str, Any], RigConfig], StepParameters]
    #: Run the procedure under the rig lock.
    run: Runner
    #: The job's label from its validated parameters: "tow 4.9 N (thrusters)".
    describe: Callable[[Any], str]
    #: ``rig <command>``.
    command: str
    #: ``POST /api/jobs/<route>``.
    route: str
    #: The estimation that takes this kind's runs: "axis" (tow/spin), "pendulum", or none.
    estimator: Literal["axis", "pendulum"] | None
    #: Write a report of a completed run into a folder → paths written (``--report DIR``),
    #: or ``None`` when the kind has no report of its own.
    report: Callable[[KindOutcome, Path], list[Path]] | None = None

    @property
    def axis(self) -> AxisTerms | None:
        """The axis the kind moves (``None`` for a calibration on the load cell)."""
        return AXES.get(self.kind)


async def _run_motion(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.motion import run_motion_test

    return KindOutcome(await run_motion_test(session, params, abort=abort, progress=progress))


async def _run_pendulum(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.pendulum import run_pendulum_decay

    return KindOutcome(await run_pendulum_decay(session, params, abort=abort, progress=progress))


async def _run_calibration(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.calibration import run_thrust_calibration

    outcome, calibration = await run_thrust_calibration(
        session, params, abort=abort, progress=progress
    )
    return KindOutcome(outcome, {"calibration": calibration})


def _calibration_report(outcome: KindOutcome, folder: Path) -> list[Path]:
    from estimation.thrust.report import write_calibration_report

    return write_calibration_report(outcome.extra["calibration"], folder)


def _driven(name: str, load: float, unit: str, drive: str) -> str:
    return f"{name} {load:.4g} {unit}" + (" (thrusters)" if drive == "thrusters" else "")


#: Every run kind. ``KINDS["tow"]`` works too: a ``RunKind`` hashes as its string.
KINDS: dict[str, KindSpec] = {  # keyed by RunKind (a str), looked up by stored strings
    spec.kind: spec
    for spec in (
        KindSpec(
            kind=RunKind.TOW,
            label="tow test",
            help="Tow test: a weight over the pulley (or the thrusters) pulls the vehicle "
            "along the rail.",
            request=requests.TowRequest,
            validate=tow_parameters,
            run=_run_motion,
            describe=lambda p: _driven("tow", p.force_n, "N", p.drive),
            command="tow",
            route="tow",
            estimator="axis",
        ),
        KindSpec(
            kind=RunKind.SPIN,
            label="spin test",
            help="Spin test: constant torque about the vertical axis (weight on the drum, "
            "or thrusters).",
            request=requests.SpinRequest,
            validate=spin_parameters,
            run=_run_motion,
            describe=lambda p: _driven("spin", p.torque_nm, "N·m", p.drive),
            command="spin",
            route="spin",
            estimator="axis",
        ),
        KindSpec(
            kind=RunKind.PENDULUM,
            label="pendulum free-decay test",
            help="Pendulum free decay: pull the vehicle out on the pendulum, release, record "
            "the swing.",
            request=requests.PendulumRequest,
            validate=pendulum_parameters,
            run=_run_pendulum,
            describe=lambda p: f"pendulum {p.start_angle_rad:.3g} rad",
            command="pendulum",
            route="pendulum",
            estimator="pendulum",
        ),
        KindSpec(
            kind=RunKind.THRUST_CALIBRATION,
            label="thrust calibration sweep",
            help="Thrust calibration: step the thrusters on the load cell and fit thrust vs "
            "command.",
            request=requests.CalibrationRequest,
            validate=calibration_parameters,
            run=_run_calibration,
            describe=lambda p: "thrust calibration",
            command="calibrate-thrusters",
            route="calibration",
            estimator=None,
            report=_calibration_report,
        ),
    )
}
