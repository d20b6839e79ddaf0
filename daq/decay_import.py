"""The free-decay kind: a record of one degree of freedom (surge, sway, heave, roll, pitch,
yaw) released from an offset and left to settle, imported from a CSV (``rig import FILE
--kind decay --dof heave``) and estimated with the single-DOF equation of motion
(``estimation.motion.decay_estimate.estimate_records``)::

    (M_known + M)·ẍ + B₁·ẋ + [B₂·|ẋ|·ẋ + …] + k·x + [k₃·x³] = 0

A free decay scales every coefficient alike, so it needs one fact from outside: the linear
stiffness ``stiffness`` (ρ·g·A_w for heave, Δ·g·GM for roll) or the inertia; the body's own
inertia (``known_inertia``) makes the identified one the added inertia. Everything here is
what the registry entry (``daq.procedures.run_kinds``) holds: the import fields and rule, the
loader and the estimator.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from daq.estimators import OUTPUT_ERROR, Estimator
from daq.import_rules import ImportRules, Planning, checked_fields, no_drive
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.vocabulary import AXES, RunKind

if TYPE_CHECKING:
    from pathlib import Path

    import numpy as np

    from daq.session import RigSource
    from daq.store import RunInfo, Store
    from estimation.design.planning_envelope import RigEnvelope
    from estimation.uncertainty.budget import Budget

Dof = Literal["surge", "sway", "heave", "roll", "pitch", "yaw"]


class DecayImport(BaseModel):
    """A free decay's own import fields (``rig import`` options, HTTP query parameters)."""

    model_config = ConfigDict(extra="forbid")
    dof: Annotated[
        Dof | None,
        Field(description="The degree of freedom (m for surge/sway/heave, rad for "
              "roll/pitch/yaw); required for --kind decay; a tow's heave, surge (default) or "
              "sway, the name its results and reports use."),
        Flag("--dof"),
    ] = None  # fmt: skip
    stiffness: Annotated[
        float | None,
        Field(gt=0, description="Free decay: the known linear restoring stiffness, N/m or "
              "N·m/rad (heave ρ·g·A_w, roll Δ·g·GM); without it the inertia scale is not "
              "identified."),
        Flag("--stiffness", metavar="K"),
    ] = None  # fmt: skip
    known_inertia: Annotated[
        float | None,
        Field(ge=0, description="Free decay: the body's own mass or inertia, kg or kg·m² "
              "(the identified inertia is then the added one)."),
        Flag("--known-inertia", metavar="M"),
    ] = None  # fmt: skip
    stiffness_tolerance: Annotated[
        float | None,
        Field(ge=0, allow_inf_nan=False, description="Free decay: the half-width within "
              "which --stiffness is known (rectangular), N/m or N·m/rad; a Type B row of the "
              "uncertainty budget (without it the stiffness is taken as exact)."),
        Flag("--stiffness-tolerance", metavar="HALF_WIDTH"),
    ] = None  # fmt: skip
    known_inertia_tolerance: Annotated[
        float | None,
        Field(ge=0, allow_inf_nan=False, description="Free decay: the half-width within "
              "which --known-inertia is known (rectangular), kg or kg·m²; a Type B row of "
              "the uncertainty budget."),
        Flag("--known-inertia-tolerance", metavar="HALF_WIDTH"),
    ] = None  # fmt: skip


def decay_plan(plan: Planning) -> tuple[dict[str, Any], RigSource | None]:
    """A free decay: no drive; ``dof`` required; the fields checked by :class:`DecayImport`
    (those not given taken from a towrig export's header)."""
    no_drive(plan.request, "a free decay")
    given = {k: v for k, v in plan.fields.items() if v is not None}
    for name in DecayImport.model_fields:  # a towrig export's header restores what it names
        recorded = plan.header.parameters.get(name)
        if name not in given and recorded is not None:
            given[name] = plan.restored[name] = recorded
    fields = checked_fields(DecayImport, given)
    if "dof" not in fields:
        allowed = ", ".join(Dof.__args__)  # type: ignore[attr-defined]
        raise ParameterError([("dof", None, f"a free decay names its dof: {allowed}")])
    return {"parameters": fields}, plan.rig


@dataclass(frozen=True)
class DecayRun:
    """One stored free decay as the fit takes it: ``t`` (s since the first sample), ``x``
    (m or rad), its dof, the known stiffness and inertia, and the window given at import."""

    run_id: str
    t: np.ndarray
    x: np.ndarray
    dof: str
    stiffness: float | None
    known_inertia: float
    t_release: float | None
    t_end: float | None
    #: Declared half-widths of the given inputs (``estimation.uncertainty.record_refits``).
    tolerances: dict[str, float] = field(default_factory=dict)


def load_decays(store: Store, records: Sequence[RunInfo]) -> list[DecayRun]:
    """The stored decays of ``records`` (as the estimate read them once), their samples from
    ``store``, checked to be of one dof with one known stiffness and inertia (they are fitted
    jointly); ``ValueError`` naming the run and field otherwise."""
    import numpy as np  # only when a decay is loaded: the registry stays light for ``rig --help``

    channel = AXES[RunKind.DECAY].position_channel
    runs = []
    for run in records:
        p = run.parameters
        table = store.samples(run.id)
        if channel not in table.channels:
            raise ValueError(f"run {run.id}: no {channel!r} channel in its samples")
        x = np.asarray(table.channels[channel], dtype=float)
        good = np.isfinite(x)
        runs.append(
            DecayRun(
                run.id,
                table.t[good],
                x[good],
                str(p.get("dof")),
                p.get("stiffness"),
                float(p.get("known_inertia") or 0.0),
                p.get("release_time_s"),
                p.get("end_time_s"),
                {
                    name: float(p[f"{name}_tolerance"])
                    for name in ("stiffness", "known_inertia")
                    if p.get(f"{name}_tolerance") is not None
                },
            )
        )
    first = runs[0]
    for r in runs[1:]:
        for name in ("dof", "stiffness", "known_inertia", "tolerances"):
            if getattr(r, name) != getattr(first, name):
                raise ValueError(
                    f"run_ids: run {r.run_id} has {name} {getattr(r, name)!r}, run "
                    f"{first.run_id} {getattr(first, name)!r}; allowed: decays fitted together "
                    "share their dof, stiffness and known inertia"
                )
    return runs


def fit_decays(
    runs: list[DecayRun],
    method: str,
    search: bool,
    envelope: RigEnvelope | None = None,
    exclude_outliers: bool = False,
) -> Any:
    """The joint fit of the decays (``estimate_records``); ``search``: try the library's
    candidate terms (quadratic and cubic damping, cubic stiffness, friction, bias, equilibrium
    drift); the window of a run without an end of its own is where its free decay ends;
    ``exclude_outliers``: leave out a repeat Chauvenet's criterion flags (its result's
    ``runs`` are then the others). ``envelope`` is not used: a decay's advice names no load."""
    from estimation.motion.decay_estimate import DECAY_CANDIDATES, estimate_records
    from estimation.motion.records import Record

    first = runs[0]
    return estimate_records(
        [Record(r.run_id, r.t, r.x) for r in runs],
        first.dof,
        known_inertia=first.known_inertia,
        stiffness=first.stiffness,
        t_release={r.run_id: r.t_release for r in runs if r.t_release is not None} or None,
        t_end={r.run_id: r.t_end for r in runs if r.t_end is not None} or None,
        candidates=DECAY_CANDIDATES if search else (),
        exclude_outliers=exclude_outliers,
    )


def decay_budget(records: Sequence[RunInfo], runs: list[DecayRun], result: Any) -> Budget:
    """The GUM budget of the decay's coefficients with the tolerances declared at import
    (``estimation.uncertainty.record_refits``)."""
    from estimation.uncertainty import RecordRefits, uncertainty_budget

    return uncertainty_budget(result, RecordRefits(result), runs[0].tolerances, result.repeats)


def decay_report(
    result: Any, runs: list[DecayRun], folder: Path, budget: dict[str, Any] | None
) -> list[Path]:
    """The decay report (``estimation.motion.decay_report``): coefficients, evidence, figure,
    the ``budget`` beside them."""
    from estimation.motion.decay_report import write_decay_report  # matplotlib: only when asked
    from estimation.motion.records import Record

    records = [Record(r.run_id, r.t, r.x) for r in runs]
    return write_decay_report(result, records, folder, {r.run_id: r.t_end for r in runs}, budget)


def decay_units() -> dict[str, dict[str, str]]:
    """Per dof, the unit of its position x (its coefficients carry their own units)."""
    from estimation.motion.terms import DOFS

    return {dof: {"position": "rad" if rotates else "m"} for dof, rotates in DOFS.items()}


#: Free decays: the single-DOF equation (``estimation.motion``), fitted on the trajectory.
DECAY = Estimator(
    name="decay",
    runs="decay",
    methods_of=lambda: ("output-error",),
    method_labels={"output-error": OUTPUT_ERROR},
    load=load_decays,  # type: ignore[arg-type]
    fit=fit_decays,
    subject=lambda runs: f"{runs[0].dof} decay",
    report=decay_report,  # type: ignore[arg-type]
    budget=decay_budget,  # type: ignore[arg-type]
    units_of=decay_units,
)

#: How a CSV becomes a free decay.
DECAY_IMPORT = ImportRules("x of the named --dof, m or rad", decay_plan, DecayImport)
