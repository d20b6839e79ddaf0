"""What a run kind is (``KindSpec``): everything the faces need to offer it, and the parts
kinds share. Each kind is one module of ``daq.procedures.kinds`` holding its ``SPEC``; the
registry (``daq.procedures.run_kinds``) discovers them.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from daq.procedures.params import ParameterError
from daq.procedures.procedure_request import ProcedureRequest
from daq.rig_capabilities import Capability, Needs, capability
from daq.vocabulary import AXES, AxisTerms, RunKind

if TYPE_CHECKING:
    from pathlib import Path

    from daq.config import RigConfig
    from daq.estimators import Estimator
    from daq.import_rules import ImportRules
    from daq.procedures.axis_steps import RunOutcome
    from daq.procedures.recording import AbortSignal, ProgressCallback
    from daq.session import RigSession
    from estimation.design.planning_envelope import AxisEnvelope, ReleaseEnvelope

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
    #: Where the kind stands in every list the faces show (lower first).
    rank: int
    #: What the operator reads: "tow test".
    label: str
    #: One line for ``rig <command> --help`` (and the browser's form).
    help: str
    #: The request model (``daq.procedures.requests``): API body, CLI options, browser form;
    #: ``checked(raw, rig)`` gives the frozen parameters. ``None``: the rig cannot run it.
    request: type[ProcedureRequest] | None = None
    #: Run the procedure under the rig lock.
    run: Runner = field(default_factory=lambda: not_on_the_rig)
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
    #: given the thrusters' calibrated (low, high) load (None: none), or the releases it
    #: allows (a pendulum); ``None``: the planner does not choose this kind.
    envelope: (
        Callable[[RigConfig, tuple[float, float] | None], AxisEnvelope | ReleaseEnvelope] | None
    ) = None
    #: What the live plot shows of its runs by default (``thrusters``: every thruster's
    #: command); ``()``: its axis's position and rate.
    live: tuple[str, ...] = ()
    #: The parameter a run list shows of its runs, with its unit; ``None``: its axis's drive.
    shown: tuple[str, str] | None = None
    #: Why the open rig may not start it now, from the rig's state (a manual thrust run: the
    #: thrusters not armed), or None; asked when a job is submitted (HTTP 409). ``None``:
    #: nothing beyond the rig lock, the emergency stop and the hold every start is under.
    refusal: Callable[[RigSession], str | None] | None = None

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

    def check(self, raw: dict[str, Any], rig: RigConfig) -> ProcedureRequest:
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
        return self.request.checked(raw, rig)


async def not_on_the_rig(session, params, *, abort, progress) -> KindOutcome:
    """The runner of a kind the rig does not run (only imported)."""
    raise ParameterError([("kind", str(params.kind), "a kind the rig runs")])


async def run_motion(session, params, *, abort, progress) -> KindOutcome:
    """A tow or a spin: ``daq.procedures.motion.run_motion_test``."""
    from daq.procedures.motion import run_motion_test

    return KindOutcome(await run_motion_test(session, params, abort=abort, progress=progress))


def axis_channels(kind: RunKind) -> tuple[str, ...]:
    """The position channel and release coil a test on ``kind``'s axis reads and writes."""
    return (AXES[kind].position_channel, AXES[kind].release_coil)


def driven_label(name: str, load: float, unit: str, drive: str) -> str:
    """A driven run's job label: "tow 4.9 N (thrusters)"."""
    return f"{name} {load:.4g} {unit}" + (" (thrusters)" if drive == "thrusters" else "")
