"""``rig user add|list|remove``, ``rig ack-estop``, ``rig hold`` and ``rig release``:
named users with their own tokens, and the rig's safety log from the command line.

They write the database, so a running ``rig serve`` on it sees them at its next start
check: the person at the tank holds the rig with ``rig hold`` and remote starts are
refused until ``rig release``. ``--user`` names who acts: a user added with
``rig user add`` (role operator) or ``default`` (the service's own token).
"""

from __future__ import annotations

from typing import Any

import click

from api.cli.command_table import rig_command, rig_group
from api.cli.common import db_option, echo_json, fail, json_option, open_store, rig_option
from api.cli.options import request_from, request_options
from api.core.people import AckIn, HoldIn, ReleaseIn

user_option = click.option(
    "--user",
    "user_name",
    required=True,
    metavar="NAME",
    help="Who acts: an operator added with `rig user add`, or `default`.",
)


@rig_group()
def user() -> None:
    """Named users of the API: each with a token (shown once) and a role (operator starts
    and stops tests, viewer only reads)."""


@user.command("add")
@click.argument("name")
@click.option(
    "--role",
    type=click.Choice(["operator", "viewer"]),
    default="viewer",
    show_default=True,
    help="operator: start, stop, change; viewer: read only.",
)
@db_option
@json_option
def add(name, role, db_url, as_json):
    """Add user NAME and print its token once (only its SHA-256 is stored)."""
    from daq.store.people_and_safety_log import UserRepository, check_user_name

    try:
        check_user_name(name, "NAME")
    except ValueError as err:
        fail(str(err))
    if name == "default":
        fail("NAME: 'default' is not allowed (it is the service token's user)")
    store = open_store(db_url)
    try:
        token = UserRepository(store).add(name, role)
    except ValueError as err:
        fail(str(err).replace("name:", "NAME:", 1))
    finally:
        store.close()
    if as_json:
        echo_json({"name": name, "role": role, "token": token})
        return
    click.echo(f"user {name} ({role}) added; its token, shown only now:")
    click.echo(token)


@user.command("list")
@db_option
@json_option
def list_users(db_url, as_json):
    """List the users (name, role, when added); never a token."""
    from daq.store.people_and_safety_log import UserRepository
    from daq.store.run_records import to_datetime

    store = open_store(db_url)
    try:
        rows = UserRepository(store).list()
    finally:
        store.close()
    if as_json:
        echo_json([r | {"created_at": to_datetime(r["created_at"]).isoformat()} for r in rows])
        return
    click.echo("default  operator  (the service token: `rig token`)")
    for r in rows:
        added = to_datetime(r["created_at"]).astimezone().strftime("%Y-%m-%d %H:%M")
        click.echo(f"{r['name']}  {r['role']}  added {added}")


@user.command("remove")
@click.argument("name")
@db_option
def remove(name, db_url):
    """Remove user NAME: its token stops working at once."""
    from daq.store.people_and_safety_log import UserRepository

    store = open_store(db_url)
    try:
        removed = UserRepository(store).remove(name)
    finally:
        store.close()
    if not removed:
        fail(f"NAME: no user named {name!r} (`rig user list` lists them)")
    click.echo(f"user {name} removed")


def _acting(store: Any, user_name: str) -> Any:
    """The operator ``user_name`` names (exit 2 naming --user otherwise)."""
    from daq.store.people_and_safety_log import User, UserRepository

    if user_name == "default":
        return User("default", "operator")
    found = UserRepository(store).by_name(user_name)
    if found is None:
        store.close()
        fail(f"--user: no user named {user_name!r} (`rig user list` lists them)")
    elif not found.operator:
        store.close()
        fail(f"--user: {user_name!r} has role {found.role}; this needs role operator")
    return found


def _guard_command(rig_file, db_url, user_name, change) -> None:
    """Open the database, act as ``user_name`` on the rig's guard, print its state."""
    from api.cli.common import user_errors
    from api.core.job_model import JobConflict
    from api.core.rig_guard import RigGuard
    from daq.config import DEFAULT_RIG_FILE, load_rig
    from daq.store.people_and_safety_log import RigEventLog

    with user_errors():
        rig = load_rig(rig_file or DEFAULT_RIG_FILE)
    store = open_store(db_url)
    try:
        acting = _acting(store, user_name)
        guard = RigGuard(RigEventLog(store, rig.rig.name))
        try:
            event = change(guard, acting)
        except JobConflict as err:
            fail(str(err), code=1)
        except ValueError as err:
            fail(f"--{err}")
    finally:
        store.close()
    click.echo(f"{rig.rig.name}: {event['message']} ({event['user_name']})")


# The options after --user are the request body's (api.core.people), as the route takes it.
@rig_command()
@user_option
@request_options(AckIn)
@rig_option
@db_option
def ack_estop(user_name, rig_file, db_url, **chosen):
    """Acknowledge an emergency stop: the rig takes starts again (named in the log)."""
    note = request_from(AckIn, chosen).note
    _guard_command(rig_file, db_url, user_name, lambda g, u: g.acknowledge(u, note))


@rig_command()
@user_option
@request_options(HoldIn)
@rig_option
@db_option
def hold(user_name, rig_file, db_url, **chosen):
    """Hold the rig for local work: remote starts by anyone else are refused (423)."""
    reason = request_from(HoldIn, chosen).reason
    _guard_command(rig_file, db_url, user_name, lambda g, u: g.take_hold(u, reason))


@rig_command()
@user_option
@request_options(ReleaseIn)
@rig_option
@db_option
def release(user_name, rig_file, db_url, **chosen):
    """Release the hold of the rig (its holder, or another operator with --override)."""
    override = request_from(ReleaseIn, chosen).override
    _guard_command(rig_file, db_url, user_name, lambda g, u: g.release(u, override))
