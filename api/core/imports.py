"""The rules of a CSV import, one place for ``rig import`` and ``POST /api/runs/import``.

:func:`plan_import` turns what the user said (:class:`ImportQuery`), the file and the rig
file into the run's kind, parameters, origin and window times, or refuses naming the field
(``ParameterError``/``ValueError``: exit 2, 422). The kind is given or named by a towrig
export's own header (``daq.store.export_header``); each kind's own rules (its drive, its
geometry, its fields) are its registry entry's ``imports`` (``daq.import_rules``). The
header also gives the release and the vehicle, so an export imports back without restating
them; a given release or vehicle overrides it. A tow may declare the body's own
``dry_mass_kg`` and ``displacement_kg`` (``daq.import_rules.body_mass``); any CSV's leading
``# vehicle: NAME`` comment (or its ``# metadata:`` vehicle) names the vehicle when the user
does not (before the rig file's, then ``unknown``).

What needs the samples (the drive's sign against the motion, one-row files, window times
within the ``t`` range) is checked by ``daq.csv_to_store.import_csv`` while it parses.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field

from daq.import_rules import ImportRequest, Planning, body_mass
from daq.procedures.flag import Flag
from daq.procedures.params import ParameterError
from daq.procedures.run_kinds import IMPORT_KINDS, KINDS
from daq.store.export_header import ExportHeader, read_export_header, vehicle_in_header

if TYPE_CHECKING:
    from daq.session import RigSource

__all__ = ["IMPORT_KINDS", "ImportPlan", "ImportQuery", "plan_import"]

#: The registry's importable kinds, as the query's and the option's allowed words.
ImportKind = Literal[tuple(str(k) for k in IMPORT_KINDS)]  # type: ignore[valid-type]


class ImportQuery(ImportRequest):
    """What the user said about the file: ``rig import``'s options and
    ``POST /api/runs/import``'s query parameters, each declared once (``daq.import_rules``),
    and the kind, one of the registry's importable kinds."""

    kind: Annotated[
        ImportKind | None,  # type: ignore[valid-type]  # the registry's import kinds
        Field(description="What the file recorded; its position column: "
              + "; ".join(f"{k}: {s.imports.position}" for k, s in IMPORT_KINDS.items()
                          if s.imports)
              + ". Default: the kind a towrig export names in its header."),
        Flag("--kind"),
    ] = None  # fmt: skip


@dataclass(frozen=True)
class ImportPlan:
    """The import to make: ``kind``, the keyword arguments of ``daq.csv_to_store.import_csv``
    (``options``) and what the file's export header supplied (``from_header``)."""

    kind: str
    options: dict[str, Any]
    from_header: dict[str, Any] = field(default_factory=dict)


def plan_import(
    path: str | Path,
    request: ImportQuery,
    *,
    fields: dict[str, Any] | None = None,
    rig: RigSource | None = None,
    pendulum_rig: RigSource | None = None,
    rig_field: str = "rig",
) -> ImportPlan:
    """The import of ``path`` as ``request`` says, checked (module docstring);
    ``fields``: the kind's own import fields as given (``import_fields()``, a decay's ``dof``).

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
    rules = KINDS[kind].imports  # type: ignore[index]  # a RunKind key matches its string
    assert rules is not None  # _kind allows the importable kinds only
    planning = Planning(kind, request, fields or {}, header, restored, rig, pendulum_rig, rig_field)
    planned, rig = rules.plan(planning)
    options |= planned
    options["parameters"] |= body_mass(planning)
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
