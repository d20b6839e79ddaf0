"""``rig tow``, ``rig spin``, ``rig pendulum``, ``rig calibrate-thrusters``, ``rig sequence``."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import click
from sqlalchemy.exc import SQLAlchemyError

from api.cli.common import (
    ProgressView,
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    rig_option,
    run_with_signals,
    scenario_option,
    user_errors,
)
from api.cli.metadata import run_metadata
from daq.procedures.params import (
    ParameterError,
    calibration_parameters,
    pendulum_parameters,
    spin_parameters,
    tow_parameters,
)
from daq.procedures.recording import AbortSignal
from daq.rig_lock import RigInUse
from daq.session import RigSession, RigSource
from daq.store.faults import one_line


def _run_procedure(
    rig_file: str | None,
    scenario_file: str | None,
    db_url: str | None,
    validate: Callable[[RigSource], Any],
    body: Callable[[RigSession, Any, AbortSignal, ProgressView], Awaitable[Any]],
    title: str,
    as_json: bool,
) -> Any:
    """Validate first (nothing written on bad input), then open the rig and run."""
    with user_errors():
        source = RigSource.load(rig_file, scenario_file)
        params = validate(source)
    note = getattr(params, "adjustment", lambda: None)()
    if note:  # the weight hangs to the gram: say what the run really applies
        click.echo(f"note: {flag_names(click.get_current_context(silent=True), note)}", err=True)
    store = open_store(db_url)

    async def main(abort: AbortSignal) -> Any:
        from daq.plc import DeviceError
        from daq.procedures.motion import PreconditionFailed
        from thrusters.driver import ThrusterError

        with ProgressView(not as_json, title) as view:
            try:
                async with RigSession(source, store) as session:
                    session.run_metadata = run_metadata()  # --operator, --tag, … (cli_metadata)
                    return await body(session, params, abort, view)
            except (PreconditionFailed, RigInUse, DeviceError, ThrusterError) as err:
                # Not ready, the rig in use, or a device that cannot be reached: exit 1.
                fail(str(err), code=1)
            except ParameterError as err:  # checks that need the rig's state (a calibration)
                fail(flag_names(click.get_current_context(silent=True), "; ".join(err.lines())))
            except SQLAlchemyError as err:  # storage failed outside a run (its start, say)
                fail(f"storage failed: {one_line(err)}", code=1)

    try:
        return run_with_signals(main)
    finally:
        store.close()


def _print_outcome(outcome: Any, as_json: bool, extra: dict | None = None) -> None:
    data = outcome.to_json() | (extra or {})
    if as_json:
        echo_json(data)
    else:
        line = f"run {data['run_id']}  {data['kind']}  {data['status']}"
        if data.get("reason"):
            line += f" ({data['reason']})"
        click.echo(line + f"  {data['samples']} samples")
    if data["status"] != "completed":
        raise SystemExit(1)


_max_time_option = click.option(
    "--max-time", "max_time_s", type=float, help="Stop after this many seconds (default 120)."
)
_baseline_option = click.option(
    "--baseline",
    "baseline_s",
    type=float,
    default=1.0,
    show_default=True,
    help="Pre-trigger baseline, s.",
)


async def _motion(session: RigSession, params: Any, abort: AbortSignal, view: ProgressView) -> Any:
    from daq.procedures.motion import run_motion_test

    return await run_motion_test(session, params, abort=abort, progress=view)


def _motion_command(validate, raw, rig_file, scenario_file, db_url, as_json, title) -> None:
    """Shared body of ``rig tow`` and ``rig spin``: options left unset take their defaults."""
    given = {k: v for k, v in raw.items() if v is not None}
    outcome = _run_procedure(
        rig_file, scenario_file, db_url, lambda s: validate(given, s.rig), _motion, title, as_json
    )
    _print_outcome(outcome, as_json)


@click.command()
@click.option(
    "--force", "force_n", type=float, help="Towing force in N (0 < F ≤ the rig's max_force_n)."
)
@click.option(
    "--weight", "weight_kg", type=float, help="Hung weight in kg (force = weight × the rig's g)."
)
@click.option(
    "--thrusters",
    "use_thrusters",
    is_flag=True,
    help="Drive the force with the calibrated thrusters (no weight).",
)
@click.option(
    "--max-distance",
    "max_distance_m",
    type=float,
    help="Stop after this many metres (default: end of travel).",
)
@_max_time_option
@_baseline_option
@rig_option
@scenario_option
@db_option
@json_option
def tow(use_thrusters, rig_file, scenario_file, db_url, as_json, **raw):
    """Tow test: a weight over the pulley (or the thrusters) pulls the vehicle along the rail."""
    raw["drive"] = "thrusters" if use_thrusters else "weight"
    _motion_command(tow_parameters, raw, rig_file, scenario_file, db_url, as_json, "tow")


@click.command()
@click.option(
    "--torque", "torque_nm", type=float, help="Torque in N·m (0 < τ ≤ the rig's max_torque_nm)."
)
@click.option(
    "--weight",
    "weight_kg",
    type=float,
    help="Weight on the drum in kg (τ = weight × g × drum radius).",
)
@click.option(
    "--thrusters",
    "use_thrusters",
    is_flag=True,
    help="Drive the torque with the calibrated thrusters.",
)
@click.option(
    "--max-angle",
    "max_angle_rad",
    type=float,
    help="Stop after this angle, rad (default: cord length).",
)
@_max_time_option
@_baseline_option
@rig_option
@scenario_option
@db_option
@json_option
def spin(use_thrusters, rig_file, scenario_file, db_url, as_json, **raw):
    """Spin test: constant torque about the vertical axis (weight on the drum, or thrusters)."""
    raw["drive"] = "thrusters" if use_thrusters else "weight"
    _motion_command(spin_parameters, raw, rig_file, scenario_file, db_url, as_json, "spin")


@click.command()
@click.option(
    "--angle",
    "start_angle_rad",
    type=float,
    help="Start angle, rad (0 < φ₀ ≤ the rig file's pendulum max_angle_rad).",
)
@click.option(
    "--stop-amplitude",
    "stop_amplitude_rad",
    type=float,
    help="Stop once the amplitude over the last full cycle is below this, rad (default 0.005).",
)
@_max_time_option
@_baseline_option
@rig_option
@scenario_option
@db_option
@json_option
def pendulum(rig_file, scenario_file, db_url, as_json, **raw):
    """Pendulum free decay: pull the vehicle out on the pendulum, release, record the swing."""
    given = {k: v for k, v in raw.items() if v is not None}

    async def body(session, params, abort, view):
        from daq.procedures.pendulum import run_pendulum_decay

        return await run_pendulum_decay(session, params, abort=abort, progress=view)

    outcome = _run_procedure(
        rig_file,
        scenario_file,
        db_url,
        lambda s: pendulum_parameters(given, s.rig),
        body,
        "pendulum",
        as_json,
    )
    _print_outcome(outcome, as_json)


@click.command("calibrate-thrusters")
@click.option(
    "--commands",
    default=None,
    metavar="LIST",
    help="Comma-separated command fractions (default 0,0.1,...,0.8); "
    "swept up then down, then reversed.",
)
@click.option(
    "--settle",
    "settle_s",
    type=float,
    default=1.0,
    show_default=True,
    help="Settling time per step, s.",
)
@click.option(
    "--samples",
    "samples_per_step",
    type=int,
    default=10,
    show_default=True,
    help="Samples averaged per step.",
)
@click.option("--no-reverse", is_flag=True, help="Forward sweep only.")
@rig_option
@scenario_option
@db_option
@json_option
def calibrate_thrusters(
    commands, settle_s, samples_per_step, no_reverse, rig_file, scenario_file, db_url, as_json
):
    """Thrust calibration: step the thrusters on the load cell and fit thrust vs command."""
    raw: dict[str, Any] = {
        "settle_s": settle_s,
        "samples_per_step": samples_per_step,
        "reverse": not no_reverse,
    }
    if commands:
        try:
            raw["commands"] = [float(c) for c in commands.split(",")]
        except ValueError:
            fail(f"commands: {commands!r} is not allowed; a comma-separated list of numbers")

    async def body(session, params, abort, view):
        from daq.procedures.calibration import run_thrust_calibration

        return await run_thrust_calibration(session, params, abort=abort, progress=view)

    outcome, calibration = _run_procedure(
        rig_file,
        scenario_file,
        db_url,
        lambda s: calibration_parameters(raw, s.rig),
        body,
        "calibration",
        as_json,
    )
    if not as_json and calibration:
        click.echo("command   thrust/thruster [N]   supply [V]")
        for row in calibration["table"]:
            click.echo(
                f"{row['command']:+7.2f}   {row['thrust_per_thruster_n']:+15.3f}   "
                f"{row['supply_voltage_v']:10.2f}"
            )
        _print_thrust_fit(calibration["fit"])
    _print_outcome(outcome, as_json, {"calibration": calibration} if as_json else None)


def _print_thrust_fit(fit: dict[str, Any]) -> None:
    """The fitted thrust curve: each parameter with σ and unit, then the fit's RMSE."""
    click.echo("fit parameter           value ± σ [unit]")
    for name, p in fit["parameters"].items():
        click.echo(f"{name:<22} {p['value']:.5g} ± {p['std']:.2g} [{p['unit']}]")
    click.echo(f"{'rmse':<22} {fit['rmse_n']:.3g} [N]")


@click.command("sequence")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option(
    "--rest",
    "rest_s",
    type=float,
    default=None,
    help="Override the file's rest time between runs, s.",
)
@rig_option
@scenario_option
@db_option
@json_option
def sequence(file, rest_s, rig_file, scenario_file, db_url, as_json):
    """Run a sequence file (tows, spins, calibrations; repeats and rest time)."""
    from daq.procedures.sequence import SequenceControl, load_sequence, run_sequence

    def validate(source: RigSource):
        seq = load_sequence(file, source.rig)
        if rest_s is not None:
            from dataclasses import replace

            from daq.procedures.params import ParameterError

            if not 0 <= rest_s <= 3600:
                raise ParameterError([("rest_s", rest_s, "allowed 0 ≤ rest_s ≤ 3600 s")])
            seq = replace(seq, rest_s=rest_s)
        return seq

    async def body(session, seq, abort, view):
        return await run_sequence(session, seq, control=SequenceControl(abort=abort), progress=view)

    outcome = _run_procedure(rig_file, scenario_file, db_url, validate, body, "sequence", as_json)
    if as_json:
        echo_json(outcome.to_json())
    else:
        for run in outcome.runs:
            click.echo(f"run {run.run_id}  {run.kind}  {run.status}  {run.samples} samples")
        click.echo(
            f"sequence {outcome.status}" + (f" ({outcome.reason})" if outcome.reason else "")
        )
    if outcome.status != "completed":
        raise SystemExit(1)
