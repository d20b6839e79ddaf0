"""The registry of run kinds: each kind is one entry, and every face looks it up.

An entry holds the kind's labels, its axis words (``daq.vocabulary.AXES``) and, for a kind
the rig runs, its request model (the API body, the ``rig`` options and the browser's start
form are derived from it; checked against the rig file it *is* the procedure's frozen
parameters) and the procedure that runs it; for a kind whose runs are estimated, its
estimator (``daq.estimators.Estimator``: loader, fit, methods, report); for a kind a CSV
may be imported as, its import rules (``daq.import_rules.ImportRules``); the operator acts its
procedure asks for (``daq.operator.SIMULATED_ACTS``). The HTTP routes, the
CLI commands, sequences, the job runner, the import and ``GET /api/kinds`` iterate or index
``KINDS`` (``RIG_KINDS``: those the rig runs) instead of branching on the kind.

Adding a kind the rig runs: write its procedure (a ``run_…`` coroutine), its request model
in ``daq.procedures.requests`` and one entry here (its ``rig`` command, with its help, and
its HTTP route follow from the entry). A kind that is only imported (a free decay) is one
entry with its estimator and import rules.
"""

from __future__ import annotations

import functools
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from pydantic import BaseModel

from daq.config import PENDULUM_CHANNELS
from daq.decay_import import DECAY, DECAY_IMPORT
from daq.estimators import AXIS, PENDULUM, Estimator
from daq.import_rules import ImportRules, drive_plan, pendulum_plan
from daq.procedures import requests
from daq.procedures.params import ParameterError
from daq.rig_capabilities import Capability, Needs, capability
from daq.vocabulary import AXES, AxisTerms, RunKind

if TYPE_CHECKING:
    from pathlib import Path

    from daq.config import RigConfig
    from daq.procedures.axis_steps import RunOutcome
    from daq.procedures.recording import AbortSignal, ProgressCallback
    from daq.session import RigSession
    from estimation.design.planning_envelope import AxisEnvelope

StepParameters = (
    requests.TowRequest
    | requests.SpinRequest
    | requests.CalibrationRequest
    | requests.PendulumRequest
)


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
    #: One line for ``rig <command> --help`` (and the browser's form).
    help: str
    #: The request model (``daq.procedures.requests``): API body, CLI options, browser form;
    #: ``checked(raw, rig)`` gives the frozen parameters. ``None``: the rig cannot run it.
    request: type[requests.ProcedureRequest] | None = None
    #: Run the procedure under the rig lock.
    run: Runner = field(default_factory=lambda: _not_on_the_rig)
    #: The job's label from its validated parameters: "tow 4.9 N (thrusters)".
    describe: Callable[[Any], str] = str
    #: ``rig <command>``.
    command: str | None = None
    #: ``POST /api/jobs/<route>``.
    route: str | None = None
    #: How its runs are estimated (runs sharing an estimator are fitted together).
    estimator: Estimator | None = None
    #: How a CSV is imported as this kind (``rig import --kind``); ``None``: not importable.
    imports: ImportRules | None = None
    #: Write a report of a completed run into a folder → paths written (``--report DIR``),
    #: or ``None`` when the kind has no report of its own.
    report: Callable[[KindOutcome, Path], list[Path]] | None = None
    #: Lines ``rig <command>`` prints above the outcome (a calibration's table), or ``None``.
    summary: Callable[[KindOutcome], list[str]] | None = None
    #: What the rig file must list for this kind, whatever drives it (``daq.rig_capabilities``).
    needs: Needs = field(default_factory=Needs)
    #: Tow/spin: what each drive (``weight``, ``thrusters``) needs on top of ``needs``.
    drives: dict[str, Needs] = field(default_factory=dict)
    #: The operator acts its procedure asks for (``daq.operator.SIMULATED_ACTS`` plays them
    #: on the simulated rig; a person does them on a real one).
    acts: tuple[str, ...] = ()
    #: For the test planner (``estimation.design``): the axis's loads and travel on ``rig``
    #: given the thrusters' calibrated (low, high) load (None: none); ``None``: the planner
    #: does not choose this kind.
    envelope: Callable[[RigConfig, tuple[float, float] | None], AxisEnvelope] | None = None
    #: What the live plot shows of its runs by default (``thrusters``: every thruster's
    #: command); ``()``: its axis's position and rate.
    live: tuple[str, ...] = ()
    #: The parameter a run list shows of its runs, with its unit; ``None``: its axis's drive.
    shown: tuple[str, str] | None = None

    @property
    def axis(self) -> AxisTerms | None:
        """The axis the kind moves (``None`` for a calibration on the load cell)."""
        return AXES.get(self.kind)

    @property
    def shown_parameter(self) -> tuple[str, str] | None:
        """The parameter a run list shows (``("force_n", "N")``): ``shown``, else its drive."""
        terms = self.axis
        if self.shown is not None or terms is None or terms.drive_key is None:
            return self.shown
        return terms.drive_key, str(terms.drive_unit)

    @property
    def live_channels(self) -> tuple[str, ...]:
        """What the live plot shows of its runs by default: ``live``, else its axis's
        position and the rate derived from it."""
        terms = self.axis
        if self.live or terms is None:
            return self.live
        return (terms.position_channel, *((terms.rate,) if terms.rate else ()))

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
        """Refuse (``NotCapable``) what the rig cannot do, then check the request against
        the rig (``request.checked``) → the frozen parameters."""
        if self.request is None:
            raise ParameterError([("kind", str(self.kind), "a kind the rig runs")])
        base = capability(str(self.kind), self.needs, rig)
        if not base.available:
            raise NotCapable("kind", str(self.kind), str(base.reason), rig.rig.name)
        drive = raw.get("drive", "weight")
        if drive in self.drives:
            can = self.capability(rig, drive)
            if not can.available:
                raise NotCapable("drive", drive, str(can.reason), rig.rig.name)
        return self.request.checked(raw, rig)  # type: ignore[return-value]


def capabilities(rig: RigConfig) -> dict[str, dict[str, Any]]:
    """What ``rig`` can do, per run kind (``GET /api/rig`` → ``capabilities``)."""
    return {str(kind): spec.describe_capability(rig) for kind, spec in RIG_KINDS.items()}


async def _not_on_the_rig(session, params, *, abort, progress) -> KindOutcome:
    raise ParameterError([("kind", str(params.kind), "a kind the rig runs")])


async def _run_motion(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.motion import run_motion_test

    return KindOutcome(await run_motion_test(session, params, abort=abort, progress=progress))


async def _run_pendulum(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.pendulum import run_pendulum_decay

    return KindOutcome(await run_pendulum_decay(session, params, abort=abort, progress=progress))


async def _run_calibration(session, params, *, abort, progress) -> KindOutcome:
    from daq.procedures.thrust_calibration import run_thrust_calibration

    outcome, calibration = await run_thrust_calibration(
        session, params, abort=abort, progress=progress
    )
    return KindOutcome(outcome, {"calibration": calibration})


def _calibration_report(outcome: KindOutcome, folder: Path) -> list[Path]:
    from estimation.thrust.calibration_report import write_calibration_report

    return write_calibration_report(outcome.extra["calibration"], folder)


def _calibration_table(outcome: KindOutcome) -> list[str]:
    """Command, thrust per thruster and supply voltage, one row a step (none: no table)."""
    calibration = outcome.extra.get("calibration")
    if not calibration:
        return []
    lines = ["command   thrust/thruster [N]   supply [V]"]
    for row in calibration["table"]:
        supply = row["supply_voltage_v"]
        lines.append(
            f"{row['command']:+7.2f}   {row['thrust_per_thruster_n']:+15.3f}   "
            + (f"{supply:10.2f}" if supply is not None else "")
        )
    return lines


def _axis_channels(kind: RunKind) -> tuple[str, ...]:
    """The position channel and release coil a test on ``kind``'s axis reads and writes."""
    return (AXES[kind].position_channel, AXES[kind].release_coil)


def _tow_envelope(rig: RigConfig, span: tuple[float, float] | None) -> AxisEnvelope:
    from estimation.design.planning_envelope import AxisEnvelope

    geometry, limits = rig.geometry, rig.limits
    return AxisEnvelope(
        "surge",
        max_load=float(limits.max_force_n),
        travel=float(geometry.end_of_travel_m),
        reverse_travel=float(geometry.reverse_travel),
        max_rate=float(limits.max_speed_m_s),
        thruster_range=span,
    )


def _spin_envelope(rig: RigConfig, span: tuple[float, float] | None) -> AxisEnvelope:
    from estimation.design.planning_envelope import AxisEnvelope

    geometry, limits = rig.geometry, rig.limits
    return AxisEnvelope(
        "yaw",
        max_load=float(limits.max_torque_nm or 0.0),  # a spin needs it (its ``needs``)
        travel=float(geometry.spin_max_angle_rad),
        reverse_travel=float(geometry.spin_max_angle_rad),
        max_rate=float(limits.max_yaw_rate_rad_s),
        thruster_range=span,
        drum_radius_m=geometry.spin_drum_radius_m,
    )


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
            run=_run_motion,
            describe=lambda p: _driven("tow", p.force_n, "N", p.drive),
            command="tow",
            route="tow",
            estimator=AXIS,
            imports=ImportRules("tow position, m", drive_plan),
            needs=Needs(channels=_axis_channels(RunKind.TOW)),
            drives={"weight": Needs(), "thrusters": Needs(thrusters=True)},
            acts=("hang_tow_weight", "return_carriage", "unmount_thrust_stand"),
            envelope=_tow_envelope,
        ),
        KindSpec(
            kind=RunKind.SPIN,
            label="spin test",
            help="Spin test: constant torque about the vertical axis (weight on the drum, "
            "or thrusters).",
            request=requests.SpinRequest,
            run=_run_motion,
            describe=lambda p: _driven("spin", p.torque_nm, "N·m", p.drive),
            command="spin",
            route="spin",
            estimator=AXIS,
            imports=ImportRules("spin angle, rad", drive_plan),
            needs=Needs(channels=_axis_channels(RunKind.SPIN), settings=("limits.max_torque_nm",)),
            drives={
                "weight": Needs(settings=("geometry.spin_drum_radius_m",)),
                "thrusters": Needs(thrusters=True),
            },
            acts=("hang_spin_weight", "return_carriage", "unmount_thrust_stand"),
            envelope=_spin_envelope,
        ),
        KindSpec(
            kind=RunKind.PENDULUM,
            label="pendulum free-decay test",
            help="Pendulum free decay: pull the vehicle out on the pendulum, release, record "
            "the swing.",
            request=requests.PendulumRequest,
            run=_run_pendulum,
            describe=lambda p: f"pendulum {p.start_angle_rad:.3g} rad",
            command="pendulum",
            route="pendulum",
            estimator=PENDULUM,
            imports=ImportRules("pendulum angle, rad (--rig gives the geometry)", pendulum_plan),
            needs=Needs(channels=PENDULUM_CHANNELS, pendulum=True),
            acts=("mount_pendulum", "pull_pendulum"),
            shown=("start_angle_rad", "rad"),
        ),
        KindSpec(
            kind=RunKind.THRUST_CALIBRATION,
            label="thrust calibration sweep",
            help="Thrust calibration: step the thrusters on the load cell and fit thrust vs "
            "command.",
            request=requests.CalibrationRequest,
            run=_run_calibration,
            describe=lambda p: "thrust calibration",
            command="calibrate-thrusters",
            route="calibration",
            report=_calibration_report,
            summary=_calibration_table,
            needs=Needs(channels=("load_cell",), thrusters=True),
            acts=("mount_thrust_stand", "unmount_thrust_stand"),
            live=("load_cell", "thrusters"),
        ),
        KindSpec(
            kind=RunKind.DECAY,
            label="free decay",
            help="Free decay: a body released from an offset in one degree of freedom "
            "(imported: rig import FILE --kind decay --dof heave).",
            estimator=DECAY,
            imports=DECAY_IMPORT,
        ),
    )
}

#: The kinds the rig runs (a procedure, a request model, a route and a command).
RIG_KINDS: dict[str, KindSpec] = {k: s for k, s in KINDS.items() if s.request is not None}
#: The kinds a CSV may be imported as (``rig import --kind``, ``POST /api/runs/import``).
IMPORT_KINDS: dict[str, KindSpec] = {k: s for k, s in KINDS.items() if s.imports is not None}


@functools.cache
def import_fields() -> type[BaseModel]:
    """One model holding every importable kind's own import fields (a free decay's
    ``dof``): the ``rig import`` options and the HTTP import's query parameters. Which kind
    takes which is its import rule's check."""
    models = [s.imports.fields for s in IMPORT_KINDS.values() if s.imports and s.imports.fields]
    return type("ImportFields", (*models, BaseModel), {"__doc__": import_fields.__doc__})


def all_methods() -> tuple[str, ...]:
    """Every estimation method some kind's estimator takes (``rig estimate --method``,
    ``POST /api/jobs/estimation``), each once; which kind takes which is checked per run."""
    return tuple(
        dict.fromkeys(m for s in KINDS.values() if s.estimator for m in s.estimator.methods)
    )
