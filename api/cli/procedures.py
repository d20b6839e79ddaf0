"""One ``rig`` command per kind the rig runs (``daq.procedures.run_kinds.RIG_KINDS``: its name,
help and options from the kind's entry and request model; ``rig tow``, ``rig spin``, …) and
``rig sequence``."""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    ProgressView,
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    report_option,
    rig_option,
    run_with_signals,
    scenario_option,
    user_errors,
)
from api.cli.metadata import run_metadata
from api.cli.options import request_fields, request_options
from api.core.sequence_request import SequenceRequest
from daq.collector import freeze_after_startup
from daq.procedures.kind_spec import KindSpec
from daq.procedures.params import ParameterError
from daq.procedures.recording import AbortSignal
from daq.procedures.run_kinds import RIG_KINDS
from daq.rig_lock import RigInUse, RigLockError, RigLockLost
from daq.session import RigSession, RigSource
from daq.store.faults import StorageFault, StorageUnavailable, one_line
from daq.vocabulary import RunStatus


def run_procedure(
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
    _refuse_after_estop(store, source)
    _refuse_when_full(store)

    async def main(abort: AbortSignal) -> Any:
        from daq.operator import OperatorActUnavailable
        from daq.plc import DeviceError
        from daq.procedures.axis_steps import PreconditionFailed
        from thrusters.driver import ThrusterError

        with ProgressView(not as_json, title) as view:
            try:
                # Real-time where the OS allows, as `rig serve`: on a busy PC the clock and
                # the simulated PLC keep their time (daq.priority).
                async with RigSession(source, store, realtime=True) as session:
                    session.run_metadata = run_metadata()  # --operator, --tag, … (cli_metadata)
                    # A lost lease stops whatever the procedure waits on (a run, a prompt).
                    session.add_fault_listener(abort.set)
                    freeze_after_startup()  # full GC passes skip what start-up loaded
                    return await body(session, params, abort, view)
            except StorageUnavailable as err:  # outside a run (its start, say)
                fail(f"storage failed: {one_line(err)}", code=1)
            except (
                PreconditionFailed,
                RigInUse,
                RigLockError,
                RigLockLost,
                DeviceError,
                ThrusterError,
                OperatorActUnavailable,
                StorageFault,
            ) as err:
                # Not ready, the rig in use, a device that cannot be reached, or a database
                # that refused the run: exit 1.
                fail(str(err), code=1)
            except ParameterError as err:  # checks that need the rig's state (a calibration)
                fail(flag_names(click.get_current_context(silent=True), "; ".join(err.lines())))

    try:
        return run_with_signals(main)
    finally:
        store.close()


def _refuse_when_full(store: Any) -> None:
    """Exit 1 (nothing opened) while the disk the run would be stored on is full."""
    from daq.store.free_space import check_room

    try:
        check_room(store)
    except StorageFault as err:
        store.close()
        fail(str(err), code=1)
    except ValueError as err:  # $RIG_MIN_FREE_BYTES set to something else than bytes
        store.close()
        fail(str(err))


def _refuse_after_estop(store: Any, source: RigSource) -> None:
    """Exit 1 (nothing opened) while the rig's emergency stop is not acknowledged
    (``rig ack-estop``): the command line moves the rig no sooner than the API."""
    from api.core.rig_guard import RigGuard
    from daq.store.people_and_safety_log import RigEventLog

    guard = RigGuard(RigEventLog(store, source.rig.rig.name))
    if guard.estop() is not None:
        refused = guard.refusal(None)
        store.close()
        fail(str(refused), code=1)


def _print_outcome(outcome: Any, as_json: bool) -> None:
    data = outcome.to_json()
    if as_json:
        echo_json(data)
    else:
        line = f"run {data['run_id']}  {data['kind']}  {data['status']}"
        if data.get("reason"):
            line += f" ({data['reason']})"
        click.echo(line + f"  {data['samples']} samples")
    if data["status"] != RunStatus.COMPLETED:
        raise SystemExit(1)


def _report_option(spec: KindSpec) -> Callable[[Callable], Callable]:
    """``--report DIR`` on the commands whose kind writes a report of its own."""

    def decorate(func: Callable) -> Callable:
        if spec.report is None:
            return func
        return report_option(
            "After a completed run, write its report (report.md and figures) to DIR."
        )(func)

    return decorate


def _write_report(spec: KindSpec, ran: Any, folder: str) -> None:
    """The kind's report of a completed run into folder (paths on stderr; stdout stays the
    outcome); a folder that cannot be written is an error after the run is stored."""
    from pathlib import Path

    if ran.run.status != RunStatus.COMPLETED:
        click.echo("report: not written, the run did not complete", err=True)
        return
    assert spec.report is not None
    try:
        paths = spec.report(ran, Path(folder))
    except OSError as err:
        fail(f"--report: cannot write {folder}: {err.strerror or err}", code=1)
    click.echo(f"report: {paths[0]}", err=True)


def procedure_command(spec: KindSpec) -> click.Command:
    """``rig <spec.command>``: the kind's request fields as options, then the procedure."""
    request = spec.request
    assert request is not None, f"{spec.kind} is not run on the rig"  # RIG_KINDS only

    async def body(session: RigSession, params: Any, abort: AbortSignal, view: ProgressView):
        return await spec.run(session, params, abort=abort, progress=view)

    @click.command(spec.command, help=spec.help)
    @request_options(request)
    @_report_option(spec)
    @rig_option
    @scenario_option
    @db_option
    @json_option
    def command(rig_file, scenario_file, db_url, as_json, report_dir=None, **values):
        given = request_fields(request, values)
        ran = run_procedure(
            rig_file,
            scenario_file,
            db_url,
            lambda source: spec.check(given, source.rig),
            body,
            spec.route,
            as_json,
        )
        if not as_json and spec.summary is not None:
            for line in spec.summary(ran):
                click.echo(line)
        if report_dir is not None:
            _write_report(spec, ran, report_dir)
        _print_outcome(ran, as_json)

    return command


#: One command per kind the rig runs, by its attribute name (``calibrate_thrusters`` for
#: ``rig calibrate-thrusters``), as ``api.cli.command_table.COMMANDS`` looks them up.
KIND_COMMANDS: dict[str, click.Command] = {
    str(spec.command).replace("-", "_"): procedure_command(spec) for spec in RIG_KINDS.values()
}


def __getattr__(name: str) -> click.Command:
    """``api.cli.procedures.tow`` and the like: the kind's command from :data:`KIND_COMMANDS`."""
    if name in KIND_COMMANDS:
        return KIND_COMMANDS[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _print_thrust_fit(fit: dict[str, Any]) -> None:
    """The fitted thrust curve: each parameter with σ and unit, then the fit's RMSE."""
    click.echo("fit parameter           value ± σ [unit]")
    for name, p in fit["parameters"].items():
        click.echo(f"{name:<22} {p['value']:.5g} ± {p['std']:.2g} [{p['unit']}]")
    click.echo(f"{'rmse':<22} {fit['rmse_n']:.3g} [N]")


@rig_command()
@click.argument("file", type=click.Path(dir_okay=False))
@request_options(SequenceRequest)  # what the file's own may be overridden by: --rest
@rig_option
@scenario_option
@db_option
@json_option
def sequence(file, rig_file, scenario_file, db_url, as_json, **chosen):
    """Run a sequence file (tows, spins, calibrations; repeats and rest time)."""
    from daq.procedures.sequence import SequenceControl, load_sequence, run_sequence

    rest_s = chosen.get("rest_s")

    def validate(source: RigSource):
        seq = load_sequence(file, source.rig)
        if rest_s is not None:
            from dataclasses import replace

            from daq.procedures.params import check_rest

            seq = replace(seq, rest_s=check_rest(rest_s))
        return seq

    async def body(session, seq, abort, view):
        return await run_sequence(session, seq, control=SequenceControl(abort=abort), progress=view)

    outcome = run_procedure(rig_file, scenario_file, db_url, validate, body, "sequence", as_json)
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
