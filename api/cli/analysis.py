"""``rig sensitivity``: which coefficients of a vehicle matter, which can go, and which
test would pin down the uncertain ones (seed 004 on the 6-DOF model)."""

from __future__ import annotations

import json
from pathlib import Path

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    estimate_option,
    fail,
    flag_names,
    json_option,
    number,
    open_store,
)
from api.cli.options import request_from, request_options
from api.core import analysis as analysis_common
from api.core import vehicle_files
from api.core.sensitivity_request import SensitivityRequest
from daq.store import ResultNotFound


def _pct(x: float | None) -> str:
    if x is None:
        return "∞"
    if x == 0:
        return "0"
    if x < 1e-4:
        return "<0.01 %"
    return f"{100 * x:.0f} %" if x >= 10 else f"{100 * x:.3g} %"


def _weights(pairs: tuple[str, ...]) -> dict[str, float] | None:
    if not pairs:
        return None
    out = {}
    for pair in pairs:
        name, _, value = pair.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            fail(f"--weight: got {pair!r}, allowed: RESPONSE=NUMBER, e.g. steady_yaw_rate=2")
    return out


def _ahp_judgements(path: str) -> dict:
    """The ``--ahp`` file's JSON; exit 2 naming the flag when it is not JSON."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        fail(f"--ahp: {path} is not a JSON file of judgement matrices ({err})")
        raise  # unreachable: fail() exits


def _print(out: dict) -> None:
    responses = list(out["weights"])
    click.echo(f"vehicle {out['vehicle']} ({out['vehicle_name']})")
    for e in out["estimates"]:
        click.echo(f"  estimate {e['result_id']} plugged in ({e['axis']})")
    click.echo("responses (weight; reference):")
    for i, name in enumerate(responses, 1):
        ref = out["reference"][name]
        mode = "" if ref["mode"] == "relative" else f"  [{ref['mode']} mode]"
        weight = out["weights"][name]
        click.echo(f"  R{i} {name:<20} {weight:.3f}; {number(ref['value'])} {ref['unit']}{mode}")
    if out["ahp"]:
        click.echo(f"  AHP CR = {out['ahp']['cr']:.3f}")
    head = f"{'coefficient':<26}{'value':>10}{'σ':>9}{'composite':>11}" + "".join(
        f"{'Sc R' + str(i):>10}" for i in range(1, len(responses) + 1)
    )
    click.echo("\nranking (knock-out Sc per response, composite = Σ Sc·Y):")
    click.echo(head)
    for row in out["ranking"]:
        flag = " keep" if row["keep"] else ""
        click.echo(
            f"{row['name']:<26}{number(row['value']):>10}{number(row['sigma']):>9}"
            f"{_pct(row['composite']):>11}"
            + "".join(f"{_pct(row['sc'][n]):>10}" for n in responses)
            + flag
        )
    if out["zero"]:
        click.echo(f"already zero (not candidates): {', '.join(out['zero'])}")
    click.echo("\nthreshold sweep (all terms below removed jointly, reduced model re-simulated):")
    click.echo(f"{'criterion':<11}{'threshold':>10}{'removed':>9}{'max error':>11}  worst response")
    for s in out["sweep"]:
        click.echo(
            f"{s['criterion']:<11}{s['threshold']:>10.4g}{s['n_removed']:>9}"
            f"{_pct(s['max_error']):>11}  {s['worst_response']}"
        )
    flips = out["weight_stability"]
    if flips:
        click.echo("weights: doubling or halving one response's weight changes these removals:")
        for f in flips:
            change = ", ".join(
                [f"+{n}" for n in f["now_removed"]] + [f"−{n}" for n in f["now_kept"]]
            )
            click.echo(f"  {f['response']} ×{f['factor']:g} at {f['threshold']:g}: {change}")
    else:
        click.echo("weights: doubling or halving any response's weight changes no removal")
    ident = out["identifiability"] or {}
    nxt = ident.get("next_test") or {}
    if nxt.get("coefficient"):
        click.echo(f"\nnext test: {nxt['test']}\n  why: {nxt['reason']}")
    elif nxt:
        click.echo(f"\nnext test: {nxt['reason']}")
    if nxt.get("unmeasured"):
        click.echo(f"  also: {nxt['unmeasured']}")
    for note in out["notes"]:
        click.echo(f"note: {note}")


@rig_command()
@click.argument("vehicle")
@estimate_option("Plug a stored estimation result in (repeatable, one per axis).")
@request_options(SensitivityRequest)
@click.option(
    "--weight",
    "weight_pairs",
    multiple=True,
    metavar="RESPONSE=W",
    help="Response weight (repeatable; default equal weights).",
)
@click.option(
    "--ahp",
    "ahp_file",
    type=click.Path(dir_okay=False, exists=True),
    help="JSON file of judgement matrices over the responses (docs/sensitivity.md).",
)
@db_option
@json_option
def sensitivity(vehicle, estimates, weight_pairs, ahp_file, db_url, as_json, **options):
    """Rank VEHICLE's coefficients (a name from fixtures/vehicles or $RIG_VEHICLES_DIR, or a
    .toml file) by their effect on standard manoeuvres, sweep thresholds for a reduced model,
    and suggest the test that would pin down the most uncertain one."""
    ahp = _ahp_judgements(ahp_file) if ahp_file else None
    # the body POST /api/analysis/sensitivity takes (api.core.sensitivity_request)
    request = request_from(
        SensitivityRequest,
        options,
        vehicle=vehicle,
        estimates=list(estimates),
        weights=_weights(weight_pairs),
        ahp=ahp,
    )
    store = open_store(db_url) if request.estimates else None
    try:
        out = analysis_common.analyse_vehicle(store, request, allow_path=True)
    except (vehicle_files.VehicleNotFound, ResultNotFound) as err:
        fail(str(err))
    except (ValueError, json.JSONDecodeError) as err:
        fail(flag_names(click.get_current_context(), str(err)))
    finally:
        if store is not None:
            store.close()
    if as_json:
        echo_json(out)
    else:
        _print(out)
