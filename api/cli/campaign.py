"""``rig campaign``: measure until certain — the planner chooses each tow/spin and pendulum
release, runs it, re-estimates, and stops at the target or the budget (docs/campaigns.md)."""

from __future__ import annotations

import uuid
from typing import Any

import click

from api.cli.command_table import rig_command
from api.cli.common import db_option, echo_json, json_option, rig_option, scenario_option
from api.cli.options import request_from, request_options
from api.core.campaign_request import CampaignRequest


def _print_entry(entry: dict[str, Any]) -> None:
    after = entry["after"]
    sigma = ", ".join(
        f"{k} {v:.3g} %" if v is not None else f"{k} —"
        for k, v in after["expanded_percent"].items()
    )
    click.echo(f"{entry['n']}. {entry['command']}  ({entry['why']})")
    click.echo(f"   U after: {sigma}; {entry['tank_minutes']:.1f} tank min")
    if after["unresolved"]:
        click.echo(f"   unresolved: {'; '.join(after['unresolved'])}")


@rig_command()
@request_options(CampaignRequest)
@rig_option
@scenario_option
@db_option
@json_option
def campaign(rig_file, scenario_file, db_url, as_json, **options):
    """Measure until certain: the planner picks each test, stops at the target or budget."""
    from api.cli.procedures import run_procedure
    from api.core.campaign_session import run_campaign
    from api.core.rig_envelope import envelope_of
    from estimation.design.campaign_state import Campaign

    # the body POST /api/campaigns takes (api.core.campaign_request)
    request = request_from(CampaignRequest, options)

    def validate(source):
        from daq.procedures.params import ParameterError

        envelope = envelope_of(source.rig)
        target = request.target(envelope)
        try:
            return Campaign(target, envelope)
        except ValueError as err:  # an axis the rig cannot test: named as --axis
            raise ParameterError(
                [("axes", list(target.axes), str(err).split(": ", 1)[-1])]
            ) from None

    async def body(session, plan, abort, view):
        plan.envelope = envelope_of(session.rig, session.store)  # with the thrusters' range
        printer = None if as_json else _print_entry
        tag = uuid.uuid4().hex[:12]
        return await run_campaign(session, plan, abort=abort, on_entry=printer, tag=tag)

    done = run_procedure(rig_file, scenario_file, db_url, validate, body, "campaign", as_json)
    if as_json:
        echo_json(done.to_json())
    else:
        click.echo(
            f"campaign: {done.outcome} ({done.runs_used} runs, {done.minutes_used:.1f} tank min)"
        )
    if done.outcome is None or not (done.outcome == "target" or done.outcome.startswith("budget")):
        raise SystemExit(1)
