"""The rules of a CSV import, one place for ``rig import`` and ``POST /api/runs/import``.

:func:`plan_import` turns what the user said (:class:`ImportRequest`), the file and the rig
file into the run's kind, parameters, origin and window times, or refuses naming the field
(``ParameterError``/``ValueError``: exit 2, 422):

- a pendulum free decay takes no drive nor weight and needs a rig file with ``[pendulum]``;
- a tow or spin takes its signed load (``force_n``/``torque_nm``, not 0; negative is a
  reverse run) or a ``drive_column`` logged per sample, not both, and optionally the hung
  ``weight_kg``; with a rig file, the load is checked against its limit (``max_force_n``,
  ``max_torque_nm``; the weight against the limit / g) and so is a logged drive's peak;
- a towrig export's own header (``daq.store.export_header``) gives the kind, the load or
  logged drive channel, the hung mass, the release and the vehicle, so the file imports
  back without restating them; what the user states must agree with it (a load or weight
  within ``AGREE``), or is refused naming both; a given release or vehicle overrides it;
- a tow may declare the body's own ``dry_mass_kg`` and ``displacement_kg`` (> 0, kg),
  kept as parameters: estimation flags an inertia identified below the body's own mass;
- any CSV's leading ``# vehicle: NAME`` comment (or its ``# metadata:`` vehicle) names the
  vehicle when the user does not (before the rig file's, then ``unknown``).

What needs the samples (the drive's sign against the motion, one-row files, window times
within the ``t`` range) is checked by ``daq.run_import.import_csv`` while it parses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from daq.body_mass import BODY_MASS_PARAMETERS
from daq.procedures.params import ParameterError
from daq.store.export_header import ExportHeader, read_export_header, vehicle_in_header
from daq.vocabulary import DRIVE_FIELD, RunKind

if TYPE_CHECKING:
    from daq.session import RigSource

#: A stated load or weight agrees with an export's header within this fraction (weights
#: hang to the gram: 1 g is 0.2 % of a 0.5 kg weight).
AGREE = 0.01
#: What ``kind`` may be.
IMPORT_KINDS = (RunKind.TOW, RunKind.SPIN, RunKind.PENDULUM)


@dataclass(frozen=True)
class ImportRequest:
    """What the user said about the file (``None``: not said)."""

    kind: str | None = None
    force_n: float | None = None
    torque_nm: float | None = None
    drive_column: str | None = None
    drive_unit: str | None = None
    weight_kg: float | None = None
    vehicle: str | None = None
    #: A tow's body: its own mass, and the mass of water it displaces (kg); an inertia
    #: identified below the body's own mass is flagged (``daq.body_mass``).
    dry_mass_kg: float | None = None
    displacement_kg: float | None = None
    time_unit: str = "s"
    release_time_s: float | None = None
    end_time_s: float | None = None


@dataclass(frozen=True)
class ImportPlan:
    """The import to make: ``kind``, the keyword arguments of ``daq.run_import.import_csv``
    (``options``) and what the file's export header supplied (``from_header``)."""

    kind: str
    options: dict[str, Any]
    from_header: dict[str, Any] = field(default_factory=dict)


def plan_import(
    path: str | Path,
    request: ImportRequest,
    *,
    rig: RigSource | None = None,
    pendulum_rig: RigSource | None = None,
    rig_field: str = "rig",
) -> ImportPlan:
    """The import of ``path`` as ``request`` says, checked (module docstring).

    ``rig``: the rig file the data were recorded on (limits, drive-train inertia, vehicle);
    ``pendulum_rig``: where a pendulum's geometry comes from when ``rig`` is not given (the
    service's rig); ``rig_field``: how errors name the rig file (``rig_file`` → ``--rig``)."""
    header = read_export_header(path)
    restored: dict[str, Any] = {}
    kind = _kind(request.kind, header, restored)
    options: dict[str, Any] = {
        "time_unit": request.time_unit,
        "release_time_s": request.release_time_s,
        "end_time_s": request.end_time_s,
    }
    if kind == RunKind.PENDULUM:
        _no_drive(request)
        rig = rig or pendulum_rig
        if rig is None:
            raise ValueError(f"{rig_field}: a pendulum import needs the rig file with its "
                             "[pendulum] geometry")  # fmt: skip
        if rig.rig.pendulum is None:
            raise ValueError(f"{rig_field}: rig {rig.rig.rig.name!r} has no [pendulum] section "
                             "(the pendulum's geometry)")  # fmt: skip
        options["parameters"] = {}
    else:
        options |= _drive(kind, request, header, restored, rig)
    options["parameters"] |= _body_mass(kind, request, header, restored)
    release = header.release_t_s if request.time_unit == "s" else None  # an export's t is s
    if request.release_time_s is None and release is not None:
        options["release_time_s"] = restored["release_time_s"] = release
    named = header.text("vehicle") or vehicle_in_header(path)  # an export's or a foreign header's
    vehicle = request.vehicle or named
    if request.vehicle is None and named:
        restored["vehicle"] = vehicle
    if rig is not None:
        options |= {
            "rig_name": rig.rig.rig.name,
            "vehicle": vehicle or rig.rig.vehicle.name,
            "rig_toml": rig.rig_toml,
        }
    else:
        options |= {
            "rig_name": header.text("rig_name") or "imported",
            "vehicle": vehicle or "unknown",
        }
    return ImportPlan(str(kind), options, restored)


def _kind(given: str | None, header: ExportHeader, restored: dict[str, Any]) -> str:
    allowed = ", ".join(map(str, IMPORT_KINDS))
    recorded = header.kind
    if given is None and recorded is None:
        raise ParameterError([("kind", None, f"allowed {allowed}; a towrig export names it "
                                             "in its header")])  # fmt: skip
    if given is not None and given not in IMPORT_KINDS:
        raise ParameterError([("kind", given, f"allowed {allowed}")])
    if recorded is not None and recorded not in IMPORT_KINDS:
        raise ValueError(f"kind: {header.source()} is a {recorded} run; allowed {allowed}")
    if given is not None and recorded is not None and given != recorded:
        raise ValueError(f"kind: {given!r} disagrees with {header.source()}; leave it out "
                         f"to import it as a {recorded}")  # fmt: skip
    if given is None:
        restored["kind"] = recorded
    return str(given or recorded)


def _no_drive(request: ImportRequest) -> None:
    given = {
        "force_n": request.force_n,
        "torque_nm": request.torque_nm,
        "drive_column": request.drive_column,
        "weight_kg": request.weight_kg,
    }
    for name, value in given.items():
        if value is not None:
            raise ValueError(f"{name}: not used by a pendulum free decay (it has no drive)")


def _limit(kind: str, rig: RigSource | None) -> tuple[str, float, float] | None:
    """The rig file's limit on the load: (name, value SI, SI load per kg hung)."""
    if rig is None:
        return None
    config = rig.rig
    if kind == RunKind.TOW:
        return "max_force_n", config.limits.max_force_n, config.rig.g
    torque, radius = config.limits.max_torque_nm, config.geometry.spin_drum_radius_m
    if torque is None:
        return None
    return "max_torque_nm", torque, config.rig.g * (radius or math.nan)


def _agrees(given: float, recorded: float) -> bool:
    return abs(given - recorded) <= AGREE * max(abs(recorded), 1e-12)


def _drive(
    kind: str,
    request: ImportRequest,
    header: ExportHeader,
    restored: dict[str, Any],
    rig: RigSource | None,
) -> dict[str, Any]:
    """A tow's or spin's drive: ``parameters`` (signed load, hung mass), ``drive_column``,
    ``drive_unit`` and ``drive_limit`` for ``import_csv``."""
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
        high = f"≤ {limit[1]:g} {unit}, rig limit {limit[0]}" if limit else f"< ∞ {unit}"
        if not (math.isfinite(load) and load != 0 and (limit is None or abs(load) <= limit[1])):
            problems.append((name, load, f"allowed 0 < |{name}| {high}; negative for a "
                                         "reverse run"))  # fmt: skip
    if weight is not None:
        most = limit[1] / limit[2] if limit else math.inf
        if not (math.isfinite(weight) and 0 < weight <= most):
            why = f" kg, rig limit {limit[0]} / g" if limit else ""
            problems.append(("weight_kg", weight, f"allowed 0 < weight_kg ≤ {most:g}{why}"))
    if problems:
        raise ParameterError(problems)
    parameters: dict[str, Any] = {} if load is None else {name: load}
    if weight is not None:
        parameters["hung_mass_kg"] = weight
    return {
        "parameters": parameters,
        "drive_column": column,
        "drive_unit": drive_unit,
        "drive_limit": limit[:2] if limit and column is not None else None,
    }


def _body_mass(
    kind: str, request: ImportRequest, header: ExportHeader, restored: dict[str, Any]
) -> dict[str, float]:
    """A tow's declared ``dry_mass_kg``/``displacement_kg`` (given, else its export
    header's), each a finite number > 0; refused for a spin or a pendulum (their body
    inertia is in kg·m²)."""
    out: dict[str, float] = {}
    for name in BODY_MASS_PARAMETERS:
        given: float | None = getattr(request, name)
        if given is not None and kind != RunKind.TOW:
            raise ParameterError([(name, given, "only for a tow (a body's own mass, kg)")])
        if given is not None and not (math.isfinite(given) and given > 0):
            raise ParameterError([(name, given, f"allowed 0 < {name} < ∞ kg")])
        value = _from_header(name, "kg", given, header.parameters, header, restored, True)
        if value is not None and kind == RunKind.TOW:
            out[name] = value
    return out


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
