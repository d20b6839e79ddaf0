"""``rig serve`` (the HTTP API and browser UI) and ``rig token``."""

from __future__ import annotations

import socket
from typing import TYPE_CHECKING

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    check_database_folder,
    db_option,
    fail,
    rig_option,
    scenario_option,
    user_errors,
)
from api.cli.warm_up import warm_up_in_background
from api.http.address_file import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    publish_address,
    published_address,
    withdraw_address,
)
from api.http.auth import TOKEN_ENV, load_or_create_token, token_file_warning, token_path

if TYPE_CHECKING:
    from api.core.jobs import JobRunner


@rig_command()
@rig_option
@scenario_option
@db_option
@click.option("--host", default="127.0.0.1", show_default=True, help="Address to bind.")
@click.option(
    "--port", default=8000, show_default=True, type=click.IntRange(0, 65535),
    help="TCP port (0 picks a free one).",
)  # fmt: skip
@click.option("--open-read", is_flag=True, help="Let read-only endpoints answer without the token.")
@click.option(
    "--allow-host", "allow_hosts", multiple=True, metavar="NAME",
    help="With --open-read, also answer requests for Host NAME (repeatable; the bound "
    "address, localhost and 127.0.0.1 always are).",
)  # fmt: skip
@click.option(
    "--cors-origin", "cors_origins", multiple=True, metavar="ORIGIN",
    help="Allow browser pages from ORIGIN (repeatable). CORS is off by default.",
)  # fmt: skip
@click.option(
    "--ask-operator/--auto-operator", default=None,
    help="Ask a person through the API for weights etc. (default: only on a hardware rig).",
)  # fmt: skip
@click.option(
    "--realtime/--no-realtime", default=True, show_default=True,
    help="Run the clock's thread SCHED_FIFO (needs CAP_SYS_NICE; falls back with a warning).",
)  # fmt: skip
@click.option(
    "--analysis-workers", metavar="ADDRESS", envvar="RIG_ANALYSIS_WORKERS", default=None,
    help="Run estimations, cross-checks, exports and studies on the Dask distributed cluster "
    "whose scheduler is at ADDRESS (tcp://host:8786; needs the 'cluster' extra; env "
    "RIG_ANALYSIS_WORKERS). Default: one worker process on this machine.",
)  # fmt: skip
def serve(
    rig_file,
    scenario_file,
    db_url,
    host,
    port,
    open_read,
    allow_hosts,
    cors_origins,
    ask_operator,
    realtime,
    analysis_workers,
):
    """Serve the HTTP API and the browser UI (binds 127.0.0.1 by default)."""
    from daq.session import RigSource

    # A bad rig file or a taken port is said before the app and its analyses are imported.
    with user_errors():
        source = RigSource.load(rig_file, scenario_file)
    check_database_folder(db_url)
    sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
    except OSError as err:
        fail(f"--host/--port: cannot bind {host}:{port}: {err.strerror}")
    bound_port = sock.getsockname()[1]
    import uvicorn

    from api.core.service import RigService, RigUnavailable
    from api.http.app import create_app

    token = load_or_create_token()
    if warning := token_file_warning():
        click.echo(warning, err=True)
    service = RigService(
        source, db_url, ask_operator=ask_operator, realtime=realtime, owner="rig serve"
    )
    # The app's lifespan stops the service (rig left safe) before uvicorn re-raises a SIGTERM.
    app = create_app(
        service,
        token=token,
        open_read=open_read,
        cors_origins=cors_origins,
        allowed_hosts=[host, *allow_hosts],
    )
    if analysis_workers:
        use_cluster(app.state.runner, analysis_workers, sock)
    # Configures logging: before the rig opens, so the device loggers keep their levels.
    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on")
    # Open the rig (and take its lock) before announcing anything: a rig another process
    # drives, or one that cannot be reached, is one line on stderr and exit code 1.
    try:
        service.start()
    except Exception as err:  # the rig is held elsewhere or unreachable, or a bad database
        sock.close()
        app.state.runner.close()
        bad_db = f"cannot open database {db_url or '(default)'}: {err}"
        fail(str(err) if isinstance(err, RigUnavailable) else bad_db, code=1)
    warming = warm_up_in_background()  # the first estimate should not wait 5-17 s for a compiler
    shown = f"[{host}]" if ":" in host else host
    where = "RIG_API_TOKEN" if _token_from_env() else f"{token_path()} (or run 'rig token')"
    click.echo(f"rig service: http://{shown}:{bound_port}/  ({source.rig.rig.name}, "
               f"{source.rig.rig.mode})")  # fmt: skip
    simulated = source.rig.rig.mode == "simulated"
    scenario = scenario_file or ("the default" if simulated else "— (hardware)")
    click.echo(f"rig file: {rig_file or 'the default (BENBAM)'}; scenario: {scenario}")
    click.echo(f"database: {_shown_url(service.store.url if service.store else db_url)}")
    # Never the token itself: this output ends up in service logs.
    click.echo(f"API token: from {where}; send 'Authorization: Bearer <token>'")
    click.echo(
        "browser UI: open the link 'rig token --link' prints, or paste the token into the page"
    )
    if host not in ("127.0.0.1", "localhost", "::1"):
        click.echo(f"warning: listening on {host}: reachable from other machines", err=True)
    server = uvicorn.Server(config)
    publish_address(host, bound_port)  # for `rig token --link`
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:  # Ctrl-C is how a person stops it: a normal shutdown
        pass
    finally:
        withdraw_address()
        service.stop()  # (already done by the lifespan, unless uvicorn never started)
        if warming.poll() is None:  # stopped within seconds: the next start compiles
            warming.kill()
        warming.wait()
    click.echo("rig service stopped: thrusters at zero, brakes on, rig released", err=True)


def _shown_url(url: str | None) -> str:
    """A database URL as it may be shown in a log: its password masked."""
    if not url:
        return "(default)"
    from daq.store.faults import shown_url

    return shown_url(url)


def ui_link(host: str, port: int, token: str) -> str:
    """The browser UI's address carrying the token (the page stores it and clears the
    address bar); a wildcard bind is linked through the loopback address."""
    from urllib.parse import quote

    if host in ("0.0.0.0", "", "::"):
        host = "127.0.0.1"
    shown = f"[{host}]" if ":" in host else host
    return f"http://{shown}:{port}/#token={quote(token, safe='')}"


def _token_from_env() -> bool:
    import os

    return bool(os.environ.get(TOKEN_ENV, "").strip())


@rig_command()
@click.option(
    "--link", is_flag=True,
    help="Print the browser UI's address with the token in it instead (open it once: the "
    "page keeps the token and takes it out of the address bar).",
)  # fmt: skip
@click.option(
    "--host", default=None,
    help=f"With --link: the address (default: the running 'rig serve''s, else {DEFAULT_HOST}).",
)  # fmt: skip
@click.option(
    "--port", default=None, type=click.IntRange(1, 65535),
    help=f"With --link: the port (default: the one the running 'rig serve' listens on, "
    f"else {DEFAULT_PORT}).",
)  # fmt: skip
def token(link, host, port):
    """Print the API's bearer token (created on first use; or set RIG_API_TOKEN). 'rig serve'
    never prints it, so it stays out of service logs."""
    secret = load_or_create_token()
    if link:
        served_host, served_port = published_address() or (DEFAULT_HOST, DEFAULT_PORT)
        click.echo(ui_link(host or served_host, port or served_port, secret))
    else:
        click.echo(secret)
    if warning := token_file_warning():
        click.echo(warning, err=True)


def use_cluster(runner: JobRunner, address: str, sock: socket.socket) -> None:
    """Send the service's analyses to the Dask cluster at ``address``; exit 2 with one line
    when the extra is not installed or no scheduler answers there."""
    try:
        from api.core.cluster_executor import ClusterUnavailable, DaskExecutor
    except ImportError:
        message = "--analysis-workers: needs the cluster extra: pip install 'towrig[cluster]'"
    else:
        try:
            runner.analysis.executor = DaskExecutor(address)
            return
        except ClusterUnavailable as err:
            message = str(err)
    sock.close()
    runner.close()
    fail(message)


if __name__ == "__main__":  # ``python -m api.cli.serve`` (what the browser test starts)
    serve()
