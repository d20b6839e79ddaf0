"""``rig predict-uncertainty SEQUENCE``: the expanded uncertainty a planned campaign will
reach on each coefficient (pre-test analysis, docs/uncertainty.md)."""

from __future__ import annotations

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, echo_json, fail, json_option, open_store, rig_option
from api.cli.options import request_from, request_options
from api.core.pretest import PretestQuery, predict_sequence
from daq.config import load_rig
from estimation.uncertainty.text import budget_lines


@rig_command()
@click.argument("sequence", type=click.Path(dir_okay=False))
@request_options(PretestQuery)
@rig_option
@db_option
@json_option
def predict_uncertainty(sequence, rig_file, db_url, as_json, **options):
    """Simulate SEQUENCE's weight-driven tows and spins with the current model and the rig
    file's declared tolerances, and print the budget and U (95 %) each coefficient will
    reach."""
    # the query GET /api/sequences/{name}/uncertainty takes (api.core.pretest.PretestQuery)
    query = request_from(PretestQuery, options)
    rig = load_rig(rig_file)
    store = open_store(db_url)
    try:
        try:
            data = predict_sequence(store, rig, sequence, query.result, query.release_std_s)
        except ValueError as err:
            fail(str(err))
    finally:
        store.close()
    if as_json:
        echo_json(data)
        return
    click.echo(f"pre-test prediction for {data['sequence']} (release σ {query.release_std_s:g} s)")
    for axis, budget in data["axes"].items():
        click.echo(f"{axis} (model {', '.join(f'{v:.4g}' for v in data['models'][axis])}):")
        for line in budget_lines(budget):
            click.echo(f"  {line}")
