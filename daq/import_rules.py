"""Per kind, how a CSV becomes a run: the rules each registry entry's ``imports`` holds
(``daq.procedures.run_kinds``), applied by ``api.core.imports.plan_import``.

- a pendulum free decay takes no drive nor weight and needs a rig file with ``[pendulum]``;
- a tow or spin takes its signed load (``force_n``/``torque_nm``, not 0; negative is a
  reverse run) or a ``drive_column`` logged per sample, not both, and optionally the hung
  ``weight_kg``; with a rig file, the load is checked against its limit (``max_force_n``,
  ``max_torque_nm``; the weight against the limit / g) and so is a logged drive's peak;
  without one, against a physical bound (``PHYSICAL_LIMITS``: 1 MN, 1 MN·m, 100 t hung):
  ``--force 1e308`` is a typo, not a tow, and would overflow the fit;
  a towrig export's header gives the load, logged drive and hung mass when not stated;
- a kind with its own import fields (``ImportRules.fields``, a pydantic model: a free
  decay's ``dof``) has them checked by that model; they are the CLI's options and the
  HTTP import's query parameters.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.vocabulary import AXES, DRIVE_FIELD

if TYPE_CHECKING:
    from daq.session import RigSource
    from daq.store.export_header import ExportHeader

#: Without a rig file, the most any tow tank applies or hangs (SI): a load or mass beyond
#: it is refused at the import, not found by the fit's numerics (``--force 1e308``).
PHYSICAL_LIMITS = {"force_n": 1e6, "torque_nm": 1e6}
#: The heaviest body or hung weight an import takes without a rig file, kg (100 t).
PHYSICAL_MAX_KG = 1e5

#: A stated load or weight agrees with an export's header within this fraction (weights
#: hang to the gram: 1 g is 0.2 % of a 0.5 kg weight).
AGREE = 0.01


class ImportRequest(BaseModel):
    """What the user said about the file (``None``: not said), one declaration for
    ``rig import``'s options and ``POST /api/runs/import``'s query (``Flag``: the option);
    the kind's allowed words are the registry's (``api.core.imports.ImportQuery``)."""

    model_config = ConfigDict(frozen=True)

    #: What the file recorded (``None``: the kind a towrig export's header names); the
    #: allowed words are the registry's (``api.core.imports.ImportQuery`` narrows it).
    kind: str | None = None
    force_n: Annotated[
        float | None,
        Field(description="Tow force, N (tow runs; negative: a reverse tow)."),
        Flag("--force"),
    ] = None
    torque_nm: Annotated[
        float | None,
        Field(description="Spin torque, N·m (spin runs; negative: a reverse spin)."),
        Flag("--torque"),
    ] = None
    drive_column: Annotated[
        str | None,
        Field(min_length=1, max_length=200,
              description="Column of the force (tow) or torque (spin) logged per sample, "
              "instead of a constant force or torque."),
        Flag("--drive-column", metavar="NAME"),
    ] = None  # fmt: skip
    drive_unit: Annotated[
        str | None,
        Field(max_length=20,
              description="Unit of the drive column: N, kN, kgf, gf, lbf (tow); N·m (or N*m), "
              "kgf·m, … (spin). Default N or N·m."),
        Flag("--drive-unit", metavar="UNIT"),
    ] = None  # fmt: skip
    weight_kg: Annotated[
        float | None,
        Field(description="Hung weight, kg, if known (estimation accounts for its inertia)."),
        Flag("--weight"),
    ] = None
    #: A tow's body: its own mass, and the mass of water it displaces (kg); an inertia
    #: identified below the body's own mass is flagged (``daq.body_mass``).
    dry_mass_kg: Annotated[
        float | None,
        Field(description="Tow: the body's own mass, kg (estimation flags an inertia below it)."),
        Flag("--dry-mass"),
    ] = None
    displacement_kg: Annotated[
        float | None,
        Field(description="Tow: the mass of water the body displaces, kg (a floating body's "
              "own mass)."),
        Flag("--displacement"),
    ] = None  # fmt: skip
    vehicle: Annotated[
        str | None,
        Field(min_length=1, max_length=200,
              description="Vehicle name (default: the export's, else the rig file's, else "
              "'unknown')."),
        Flag("--vehicle"),
    ] = None  # fmt: skip
    time_unit: Annotated[
        Literal["s", "ms", "us"],
        Field(description="Unit of the t column (a median step over 1 s is refused as not "
              "seconds)."),
        Flag("--time-unit"),
    ] = "s"  # fmt: skip
    release_time_s: Annotated[
        float | None,
        Field(description="Brake release, s on the t axis (default: found from the release "
              "coil or the motion)."),
        Flag("--release-time"),
    ] = None  # fmt: skip
    end_time_s: Annotated[
        float | None,
        Field(description="End of free motion, s on the t axis (default: end_of_travel, the "
              "brake or the carriage at rest)."),
        Flag("--end-time"),
    ] = None  # fmt: skip


@dataclass(frozen=True)
class Planning:
    """What a kind's import rule is given: the request, the kind's own import fields as
    given (``fields``: ``ImportRules.fields``), the file's export header, the
    header values taken so far (``restored``, filled in), the rig file the data were
    recorded on and the service's (``default_rig``), and how errors name the rig file."""

    kind: str
    request: ImportRequest
    fields: dict[str, Any]
    header: ExportHeader
    restored: dict[str, Any]
    rig: RigSource | None
    default_rig: RigSource | None
    rig_field: str


@dataclass(frozen=True)
class ImportRules:
    """How a CSV is imported as one kind.

    ``position``: what the file's ``position`` column holds (help text); ``plan``: the
    ``daq.store.import_csv`` options (``parameters``, a logged drive) and the rig file the
    run keeps; ``fields``: the kind's own import fields (``None``: none)."""

    position: str
    plan: Callable[[Planning], tuple[dict[str, Any], RigSource | None]]
    fields: type[BaseModel] | None = None

    def to_json(self) -> dict[str, Any]:
        """What ``GET /api/kinds`` says of the import: the position and the fields' schema."""
        schema = None if self.fields is None else self.fields.model_json_schema()
        return {"position": self.position, "schema": schema}


def checked_fields(model: type[BaseModel], given: dict[str, Any]) -> dict[str, Any]:
    """The kind's import fields checked by ``model`` (``ParameterError`` naming each bad
    one), as a run's parameters (unset ones left out)."""
    from pydantic import ValidationError

    from daq.procedures.params import problems_of

    try:
        return model.model_validate(given).model_dump(exclude_none=True)
    except ValidationError as err:
        raise ParameterError(problems_of(err)) from None


def no_drive(request: ImportRequest, what: str) -> None:
    """Refuse a drive or weight for a kind that has none (``what``: "a pendulum free decay")."""
    given = {
        "force_n": request.force_n,
        "torque_nm": request.torque_nm,
        "drive_column": request.drive_column,
        "weight_kg": request.weight_kg,
    }
    for name, value in given.items():
        if value is not None:
            raise ValueError(f"{name}: not used by {what} (it has no drive)")


def no_fields(plan: Planning, *, allowed: tuple[str, ...] = ()) -> None:
    """Refuse another kind's import fields (``--stiffness`` on a tow), all but ``allowed``."""
    for name, value in plan.fields.items():
        if value is not None and name not in allowed:
            raise ParameterError([(name, value, f"not used by a {plan.kind}")])


#: The degrees of freedom a tow may be imported as (``--dof``; default surge): the tow's
#: equation along another straight line, e.g. a sphere settling under its weight (heave).
TOW_DOFS: tuple[str, ...] = ("heave", "surge", "sway")


def tow_dof(plan: Planning) -> dict[str, str]:
    """A tow's ``dof`` as a run parameter: given (``--dof``), else its export header's;
    none when neither says (the default, surge). ``ParameterError`` naming ``dof``, the
    value and :data:`TOW_DOFS` for any other."""
    dof = plan.fields.get("dof")
    recorded = plan.header.parameters.get("dof")
    if dof is None and isinstance(recorded, str):
        dof = plan.restored["dof"] = recorded
    if dof is None:
        return {}
    if dof not in TOW_DOFS:
        allowed = ", ".join(TOW_DOFS)
        raise ParameterError([("dof", dof, f"allowed {allowed} for a tow (default surge)")])
    return {"dof": str(dof)}


def pendulum_plan(plan: Planning) -> tuple[dict[str, Any], RigSource | None]:
    """A pendulum free decay: no drive; the rig file's ``[pendulum]`` geometry."""
    no_drive(plan.request, "a pendulum free decay")
    no_fields(plan)
    rig = plan.rig or plan.default_rig
    if rig is None:
        raise ValueError(f"{plan.rig_field}: a pendulum import needs the rig file with its "
                         "[pendulum] geometry")  # fmt: skip
    if rig.rig.pendulum is None:
        raise ValueError(f"{plan.rig_field}: rig {rig.rig.rig.name!r} has no [pendulum] section "
                         "(the pendulum's geometry)")  # fmt: skip
    return {"parameters": {}}, rig


def _limit(kind: str, rig: RigSource | None) -> tuple[str, float, float] | None:
    """The rig file's limit on the load: (name, value SI, SI load per kg hung)."""
    if rig is None:
        return None
    config = rig.rig
    if DRIVE_FIELD[kind][0] == "force_n":
        return "max_force_n", config.limits.max_force_n, config.rig.g
    torque, radius = config.limits.max_torque_nm, config.geometry.spin_drum_radius_m
    if torque is None:
        return None
    return "max_torque_nm", torque, config.rig.g * (radius or math.nan)


def _load_bound(name: str, unit: str, limit: tuple[str, float, float] | None) -> tuple[float, str]:
    """The largest |load| and how the refusal says it: the rig limit, else physics."""
    if limit is not None:
        return limit[1], f"≤ {limit[1]:g} {unit}, rig limit {limit[0]}"
    most = PHYSICAL_LIMITS[name]
    return most, f"≤ {most:g} {unit}, a physical bound without a rig file"


def _agrees(given: float, recorded: float) -> bool:
    return abs(given - recorded) <= AGREE * max(abs(recorded), 1e-12)


def drive_plan(plan: Planning) -> tuple[dict[str, Any], RigSource | None]:
    """A tow's or spin's drive: ``parameters`` (signed load, hung mass), ``drive_column``,
    ``drive_unit`` and ``drive_limit`` for ``import_csv``; a tow's ``dof`` (:func:`tow_dof`)."""
    terms = AXES.get(plan.kind)
    linear = terms is not None and terms.inertia_is_mass  # a tow's straight line
    no_fields(plan, allowed=("dof",) if linear else ())
    kind, request, header, restored, rig = (
        plan.kind, plan.request, plan.header, plan.restored, plan.rig
    )  # fmt: skip
    name, unit = DRIVE_FIELD[kind]
    other = "torque_nm" if name == "force_n" else "force_n"
    load: float | None = getattr(request, name)
    weight, column, drive_unit = request.weight_kg, request.drive_column, request.drive_unit
    if getattr(request, other) is not None:
        raise ParameterError([(other, getattr(request, other), f"not used by a {kind}")])
    if column is not None and load is not None:
        raise ValueError(f"{name}: not used with drive_column (the drive is logged per sample)")
    recorded = header.parameters
    if header.is_export and load is None and column is None:
        logged = recorded.get("drive_channel")
        if isinstance(logged, str):  # an imported run's logged drive, exported in SI
            column = restored["drive_column"] = logged
            drive_unit = drive_unit or unit
        elif header.text("drive") == "thrusters":
            raise ValueError(
                f"{name}: missing; {header.source()} is thruster-driven: its thrust is rebuilt "
                f"from the thrusters' calibration, not stored in the file; give {name} or "
                "drive_column"
            )
    if drive_unit is not None and column is None:
        raise ValueError("drive_unit: only with drive_column")
    thrusters = header.text("drive") == "thrusters"  # its force_n is only what was asked
    load = _from_header(name, unit, load, recorded, header, restored, not (column or thrusters))
    weight = _from_header("hung_mass_kg", "kg", weight, recorded, header, restored, True)
    limit = _limit(kind, rig)
    problems: list[tuple[str, Any, str]] = []
    if load is None and column is None:
        problems.append((name, None, f"a {kind} needs its applied load: {name} ({unit}; "
                                     "negative for a reverse run) or drive_column"))  # fmt: skip
    elif load is not None:
        most_load, high = _load_bound(name, unit, limit)
        if not (math.isfinite(load) and load != 0 and abs(load) <= most_load):
            problems.append((name, load, f"allowed 0 < |{name}| {high}; negative for a "
                                         "reverse run"))  # fmt: skip
    if weight is not None:
        most = limit[1] / limit[2] if limit else PHYSICAL_MAX_KG
        if not (math.isfinite(weight) and 0 < weight <= most):
            why = f" kg, rig limit {limit[0]} / g" if limit else " kg, a physical bound"
            problems.append(("weight_kg", weight, f"allowed 0 < weight_kg ≤ {most:g}{why}"))
    if problems:
        raise ParameterError(problems)
    parameters: dict[str, Any] = {} if load is None else {name: load}
    if weight is not None:
        parameters["hung_mass_kg"] = weight
    if linear:
        parameters |= tow_dof(plan)
    options = {
        "parameters": parameters,
        "drive_column": column,
        "drive_unit": drive_unit,
        "drive_limit": limit[:2] if limit and column is not None else None,
    }
    return options, rig


def _from_header(
    name: str,
    unit: str,
    given: float | None,
    recorded: dict[str, Any],
    header: ExportHeader,
    restored: dict[str, Any],
    wanted: bool,
) -> float | None:
    """``given``, else the header's value of ``name`` (when ``wanted``); a given value that
    disagrees with the header is refused, one that agrees gives way to the recorded one."""
    value = recorded.get(name)
    if not wanted or not isinstance(value, int | float) or isinstance(value, bool) or not value:
        return given
    field_name = "weight_kg" if name == "hung_mass_kg" else name
    if given is not None and not _agrees(given, float(value)):
        raise ValueError(
            f"{field_name}: {given!r} disagrees with {header.source()}: {name} {value:g} {unit}; "
            "leave it out to take the header's"
        )
    restored[name] = float(value)
    return float(value)


def body_mass(plan: Planning) -> dict[str, float]:
    """A tow's declared ``dry_mass_kg``/``displacement_kg`` (given, else its export
    header's), each a number in 0 < m ≤ ``PHYSICAL_MAX_KG``; refused for another kind (a
    spin's or a pendulum's body inertia is in kg·m²)."""
    from daq.body_mass import BODY_MASS_PARAMETERS

    out: dict[str, float] = {}
    terms = AXES.get(plan.kind)
    takes_mass = terms is not None and terms.inertia_is_mass  # a tow's surge
    for name in BODY_MASS_PARAMETERS:
        given: float | None = getattr(plan.request, name)
        if given is not None and not takes_mass:
            raise ParameterError([(name, given, "only for a tow (a body's own mass, kg)")])
        if given is not None and not (math.isfinite(given) and 0 < given <= PHYSICAL_MAX_KG):
            bound = f"allowed 0 < {name} ≤ {PHYSICAL_MAX_KG:g} kg, a physical bound"
            raise ParameterError([(name, given, bound)])
        recorded = plan.header.parameters
        value = _from_header(name, "kg", given, recorded, plan.header, plan.restored, True)
        if value is not None and takes_mass:
            out[name] = value
    return out
