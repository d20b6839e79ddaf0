"""``rig import``: a CSV recorded elsewhere (or a towrig export) as a completed run.

The import's rules (kind, drive, rig limits, the export's header) are
``api.core.imports``'s, shared with ``POST /api/runs/import``; this is the command's face.
The kinds offered and each kind's own options (a free decay's ``--dof``) come from the
registry's import rules (``daq.procedures.run_kinds.IMPORT_KINDS``).
"""

from __future__ import annotations

import click

from api.cli.common import (
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    user_errors,
)
from api.cli.options import request_fields, request_options
from daq.procedures.run_kinds import IMPORT_KINDS, import_fields


@click.command("import")
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@click.option(
    "--kind",
    type=click.Choice([str(k) for k in IMPORT_KINDS]),
    help="What the file recorded; its position column: "
    + "; ".join(f"{k}: {s.imports.position}" for k, s in IMPORT_KINDS.items() if s.imports)
    + ". Default: the kind a towrig export names in its header.",
)
@click.option("--force", "force_n", type=float, help="Tow force in N (negative: a reverse tow).")
@click.option(
    "--torque", "torque_nm", type=float, help="Spin torque in N·m (negative: a reverse spin)."
)
@click.option(
    "--drive-column",
    metavar="NAME",
    help="Column with the force (tow) or torque (spin) logged per sample, instead of "
    "--force/--torque.",
)
@click.option(
    "--drive-unit",
    metavar="UNIT",
    help="Unit of --drive-column: N, kN, kgf, gf, lbf (tow); N·m (or N*m), kgf·m, … (spin). "
    "Default N or N·m.",
)
@click.option(
    "--weight",
    "weight_kg",
    type=float,
    help="Hung weight in kg, if known (lets estimation account for its inertia).",
)
@click.option(
    "--dry-mass",
    "dry_mass_kg",
    type=float,
    help="Tow: the body's own mass, kg (estimation flags an inertia below it).",
)
@click.option(
    "--displacement",
    "displacement_kg",
    type=float,
    help="Tow: the mass of water the body displaces, kg (a floating body's own mass).",
)
@click.option(
    "--vehicle", default=None, help="Vehicle name (default: the rig file's, else 'unknown')."
)
@click.option(
    "--rig",
    "rig_file",
    metavar="FILE",
    default=None,
    help="Rig file the data was recorded on (gives pulley/drum inertia to estimation).",
)
@click.option(
    "--time-unit",
    type=click.Choice(["s", "ms", "us"]),
    default="s",
    show_default=True,
    help="Unit of the t column (a median step over 1 s is refused as not seconds).",
)
@click.option(
    "--release-time",
    "release_time_s",
    type=float,
    help="Brake release, s on the t axis (default: found from the release coil or the motion).",
)
@click.option(
    "--end-time",
    "end_time_s",
    type=float,
    help="End of free motion, s on the t axis (default: end_of_travel/brake/carriage at rest).",
)
@request_options(import_fields())
@db_option
@json_option
def import_(
    file,
    kind,
    force_n,
    torque_nm,
    drive_column,
    drive_unit,
    weight_kg,
    dry_mass_kg,
    displacement_kg,
    vehicle,
    rig_file,
    time_unit,
    release_time_s,
    end_time_s,
    db_url,
    as_json,
    **kind_fields,
):
    """Import a CSV (columns t [s] and position [m or rad]; more allowed); prints the new run id.

    Estimation finds the free-motion window itself (tow_release/spin_release and
    end_of_travel columns when present, else the motion); --release-time/--end-time
    override it. A drive logged per sample: --drive-column (and --drive-unit) instead of
    --force/--torque. A pendulum decay needs --rig with a [pendulum] section (its
    geometry); its release is the first sample unless --release-time says otherwise.
    With --rig the load is checked against its limits; a constant load whose sign disagrees
    with the recorded motion is refused. A towrig export (rig export) imports back as it
    was: kind, load, hung weight, release and vehicle come from its header."""
    from api.cli.metadata import run_metadata
    from api.core.imports import ImportRequest, plan_import
    from daq.csv_to_store import import_csv
    from daq.procedures.params import ParameterError

    ctx = click.get_current_context()
    request = ImportRequest(
        kind=kind, force_n=force_n, torque_nm=torque_nm, drive_column=drive_column,
        drive_unit=drive_unit, weight_kg=weight_kg, vehicle=vehicle, time_unit=time_unit,
        release_time_s=release_time_s, end_time_s=end_time_s, dry_mass_kg=dry_mass_kg,
        displacement_kg=displacement_kg, fields=request_fields(import_fields(), kind_fields),
    )  # fmt: skip
    source = None
    if rig_file:
        from daq.session import RigSource

        with user_errors():
            source = RigSource.load(rig_file)
    with user_errors():
        try:
            plan = plan_import(file, request, rig=source, rig_field="rig_file")
        except ValueError as err:
            if isinstance(err, ParameterError):
                raise
            fail(flag_names(ctx, str(err)))
    if plan.from_header:
        taken = ", ".join(f"{k} {v}" for k, v in plan.from_header.items())
        click.echo(f"note: from the file's header: {taken}", err=True)
    store = open_store(db_url)
    try:
        try:
            run_id = import_csv(
                store, file, metadata=run_metadata(), kind=plan.kind, **plan.options
            )
        except ValueError as err:
            fail(flag_names(ctx, str(err)))
        if as_json:
            echo_json({"run_id": run_id, "from_header": plan.from_header})
        else:
            click.echo(run_id)
    finally:
        store.close()
