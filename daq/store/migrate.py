"""Opening a run database: the default URL, the engine (SQLite pragmas) and Alembic
migrations to head, all without an alembic.ini."""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import sqlalchemy as sa
from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory

from daq.data_dir import default_database_path

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"


def default_database_url() -> str:
    """``$RIG_DATABASE_URL`` if set, else SQLite at :func:`default_database_path`."""
    url = os.environ.get("RIG_DATABASE_URL", "").strip()
    if url:
        return url
    return f"sqlite:///{default_database_path()}"


#: JSON columns keep text as written (ü, not \u00fc), so a metadata search finds it.
_json_text = functools.partial(json.dumps, ensure_ascii=False)


def _set_sqlite_pragmas(dbapi_connection, _record) -> None:
    cursor = dbapi_connection.cursor()
    try:
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute("PRAGMA foreign_keys=ON")
        cursor.execute("PRAGMA busy_timeout=10000")
    finally:
        cursor.close()


def create_engine(url: str) -> sa.Engine:
    """An engine for ``url``; SQLite gets WAL, synchronous=NORMAL, foreign keys and a
    busy timeout, and the folder of its file is created."""
    try:
        parsed = sa.make_url(url)
    except sa.exc.ArgumentError as exc:
        raise ValueError(
            f"database URL {url!r} is not valid; expected e.g. sqlite:///path/rig.db or "
            "postgresql+psycopg://user@host/dbname"
        ) from exc
    if parsed.get_backend_name() == "sqlite":
        database = parsed.database or ""
        if database and database != ":memory:" and not database.startswith("file:"):
            Path(database).expanduser().parent.mkdir(parents=True, exist_ok=True)
        engine = sa.create_engine(
            parsed, connect_args={"check_same_thread": False}, json_serializer=_json_text
        )
        sa.event.listen(engine, "connect", _set_sqlite_pragmas)
        return engine
    if parsed.get_backend_name() == "postgresql":
        return sa.create_engine(parsed, pool_pre_ping=True, json_serializer=_json_text)
    raise ValueError(
        f"database URL {url!r}: backend {parsed.get_backend_name()!r} is not supported; "
        "use sqlite:/// or postgresql+psycopg://"
    )


def alembic_config(connection: sa.Connection | None = None) -> Config:
    """An Alembic Config pointing at the packaged revisions (no ini file)."""
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR).replace("%", "%%"))
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def head_revision() -> str:
    """The newest revision shipped with this package."""
    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    assert head is not None
    return head


def current_revision(engine: sa.Engine) -> str | None:
    """The revision the database is at (None for an empty database)."""
    with engine.connect() as connection:
        return MigrationContext.configure(connection).get_current_revision()


def upgrade_to_head(engine: sa.Engine) -> None:
    """Apply every pending revision in one transaction (a no-op when already at head)."""
    if current_revision(engine) == head_revision():
        return
    with engine.begin() as connection:
        if connection.dialect.name == "postgresql":
            # Serialise concurrent first opens of the same database.
            connection.exec_driver_sql("SELECT pg_advisory_xact_lock(74657273)")
        command.upgrade(alembic_config(connection), "head")
