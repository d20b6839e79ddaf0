"""``rig campaign``: measure until certain — the planner chooses each tow/spin, runs it,
re-estimates, and stops at the target or the budget (docs/campaigns.md)."""

from __future__ import annotations

import uuid
from typing import Any

import click

from api.cli.common import db_option, echo_json, json_option, rig_option, scenario_option


def parse_target(text: str) -> float:
    """``1%`` or ``1`` → 0.01 (a U/|θ| target in percent); ``click.BadParameter`` outside
    0 < target < 100 %."""
    raw = text.strip().removesuffix("%").strip()
    try:
        percent = float(raw)
    except ValueError:
        raise click.BadParameter(f"{text!r} is not a percentage (e.g. 1%)") from None
    if not 0 < percent < 100:
        raise click.BadParameter(f"{text!r}: allowed 0 < target < 100 %")
    return percent / 100


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


@click.command("campaign")
@click.option(
    "--target",
    "relative",
    default="1%",
    callback=lambda ctx, param, value: parse_target(value),
    show_default=True,
    help="U/|θ| target on inertia, K_L and K_Q, in percent (U: the expanded uncertainty of "
    "the GUM budget, 95 %, with the rig file's tolerances).",
)
@click.option(
    "--axis",
    "axes",
    type=click.Choice(["surge", "yaw"]),
    multiple=True,
    help="surge (tows) and/or yaw (spins); default both the rig can test.",
)
@click.option("--max-runs", type=click.IntRange(1, 100), default=12, show_default=True)
@click.option(
    "--max-minutes",
    type=click.FloatRange(0, 1440, min_open=True),
    default=60.0,
    show_default=True,
    help="Budget in tank minutes (runs + 30 s reset each).",
)
@rig_option
@scenario_option
@db_option
@json_option
def campaign(relative, axes, max_runs, max_minutes, rig_file, scenario_file, db_url, as_json):
    """Measure until certain: the planner picks each test, stops at the target or budget."""
    from api.cli.procedures import run_procedure
    from api.core.campaign_session import run_campaign
    from api.core.rig_envelope import envelope_of
    from estimation.design.campaign_state import Campaign, Target

    def validate(source):
        from daq.procedures.params import ParameterError

        chosen = tuple(axes) or tuple(a.axis for a in envelope_of(source.rig).axes)
        target = Target(relative, chosen, max_runs, max_minutes)
        try:
            return Campaign(target, envelope_of(source.rig))
        except ValueError as err:  # an axis the rig cannot test: named as --axis
            raise ParameterError([("axes", list(chosen), str(err).split(": ", 1)[-1])]) from None

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
