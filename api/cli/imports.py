"""``rig import``: a CSV recorded elsewhere (or a towrig export) as a completed run.

The import's rules (kind, drive, rig limits, the export's header) are
``api.core.imports``'s, shared with ``POST /api/runs/import``; this is the command's face.
Its options are ``api.core.imports.ImportQuery``'s fields, the route's query parameters; the
kinds offered and each kind's own options (a free decay's ``--dof``) come from the
registry's import rules (``daq.procedures.run_kinds.IMPORT_KINDS``).
"""

from __future__ import annotations

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    user_errors,
)
from api.cli.options import request_fields, request_from, request_options
from api.core.imports import ImportQuery
from daq.procedures.run_kinds import import_fields


@rig_command()
@click.argument("file", type=click.Path(exists=True, dir_okay=False))
@request_options(ImportQuery)
@click.option(
    "--rig",
    "rig_file",
    metavar="FILE",
    default=None,
    help="Rig file the data was recorded on (gives pulley/drum inertia to estimation).",
)
@request_options(import_fields())
@db_option
@json_option
def import_(file, rig_file, db_url, as_json, **options):
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
    from api.core.imports import plan_import
    from daq.csv_to_store import import_csv
    from daq.procedures.params import ParameterError

    ctx = click.get_current_context()
    # the query POST /api/runs/import takes (api.core.imports.ImportQuery)
    request = request_from(ImportQuery, options)
    source = None
    if rig_file:
        from daq.session import RigSource

        with user_errors():
            source = RigSource.load(rig_file)
    with user_errors():
        try:
            plan = plan_import(
                file,
                request,
                fields=request_fields(import_fields(), options),
                rig=source,
                rig_field="rig_file",
            )
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
