"""Alembic environment for the run database.

There is no alembic.ini: ``daq.store.migrate`` builds the Config in code and passes an
open connection in ``config.attributes["connection"]``.
"""

from __future__ import annotations

from alembic import context

from daq.store.schema import metadata

config = context.config


def run_migrations_online() -> None:
    """Run the revisions on the connection handed over by ``daq.store.migrate``."""
    connection = config.attributes.get("connection")
    if connection is None:
        raise RuntimeError("daq.store migrations need a connection in config.attributes")
    context.configure(
        connection=connection,
        target_metadata=metadata,
        render_as_batch=connection.dialect.name == "sqlite",
        compare_type=True,
    )
    with context.begin_transaction():
        context.run_migrations()


if context.is_offline_mode():
    raise RuntimeError("offline (SQL script) migrations are not supported")
run_migrations_online()
