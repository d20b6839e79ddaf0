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

from daq.capabilities import Capability, Needs, capability
from daq.config import PENDULUM_CHANNELS
from daq.procedures import requests
from daq.procedures.params import (
    CalibrationParameters,
    ParameterError,
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


#: How a reason names a drive ("tow with thrusters: needs a [thrusters] section").
DRIVE_WORDS = {"weight": "with a hung weight", "thrusters": "with thrusters"}


class NotCapable(ParameterError):
    """The rig file lacks what a run kind (or its drive) needs; nothing was started.

    One line per refusal, e.g. ``rig 'Encoder tow rig' cannot run a spin test: needs
    channel yaw_angle, channel spin_release``; the API answers it with 409."""

    def __init__(self, field_name: str, value: Any, reason: str, rig_name: str) -> None:
        self.reason = reason
        self.rig_name = rig_name
        super().__init__([(field_name, value, reason)])

    def lines(self) -> list[str]:
        return [f"rig {self.rig_name!r} cannot do this: {self.reason}"]


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
    #: What the rig file must list for this kind, whatever drives it (``daq.capabilities``).
    needs: Needs = field(default_factory=Needs)
    #: Tow/spin: what each drive (``weight``, ``thrusters``) needs on top of ``needs``.
    drives: dict[str, Needs] = field(default_factory=dict)

    @property
    def axis(self) -> AxisTerms | None:
        """The axis the kind moves (``None`` for a calibration on the load cell)."""
        return AXES.get(self.kind)

    def capability(self, rig: RigConfig, drive: str | None = None) -> Capability:
        """Can ``rig`` run this kind (with ``drive``; ``None``: with any of its drives)?"""
        name = str(self.kind)
        base = capability(name, self.needs, rig)
        if not base.available or not self.drives:
            return base
        if drive is not None and drive in self.drives:
            return capability(f"{name} {DRIVE_WORDS[drive]}", self.drives[drive], rig)
        each = {d: self.capability(rig, d) for d in self.drives}
        if any(c.available for c in each.values()):
            return Capability(True)
        return Capability(False, "; ".join(str(c.reason) for c in each.values()))

    def describe_capability(self, rig: RigConfig) -> dict[str, Any]:
        """``{"available", "reason"?, "drives"?: {drive: {"available", "reason"?}}}``."""
        out = self.capability(rig).to_json()
        if self.drives:
            out["drives"] = {d: self.capability(rig, d).to_json() for d in self.drives}
        return out

    def check(self, raw: dict[str, Any], rig: RigConfig) -> StepParameters:
        """Refuse (``NotCapable``) what the rig cannot do, then validate the request."""
        base = capability(str(self.kind), self.needs, rig)
        if not base.available:
            raise NotCapable("kind", str(self.kind), str(base.reason), rig.rig.name)
        drive = raw.get("drive", "weight")
        if drive in self.drives:
            can = self.capability(rig, drive)
            if not can.available:
                raise NotCapable("drive", drive, str(can.reason), rig.rig.name)
        return self.validate(raw, rig)


def capabilities(rig: RigConfig) -> dict[str, dict[str, Any]]:
    """What ``rig`` can do, per run kind (``GET /api/rig`` → ``capabilities``)."""
    return {str(kind): spec.describe_capability(rig) for kind, spec in KINDS.items()}


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


def _axis_channels(kind: RunKind) -> tuple[str, ...]:
    """The position channel and release coil a test on ``kind``'s axis reads and writes."""
    return (AXES[kind].position_channel, AXES[kind].release_coil)


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
            needs=Needs(channels=_axis_channels(RunKind.TOW)),
            drives={"weight": Needs(), "thrusters": Needs(thrusters=True)},
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
            needs=Needs(channels=_axis_channels(RunKind.SPIN), settings=("limits.max_torque_nm",)),
            drives={
                "weight": Needs(settings=("geometry.spin_drum_radius_m",)),
                "thrusters": Needs(thrusters=True),
            },
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
            needs=Needs(channels=PENDULUM_CHANNELS, pendulum=True),
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
            needs=Needs(channels=("load_cell",), thrusters=True),
        ),
    )
}
