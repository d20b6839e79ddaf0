"""Opening a run database: the default URL, the engine (SQLite pragmas), the head schema
made at once in a new database and Alembic migrations of an older one, without an alembic.ini."""

from __future__ import annotations

import contextlib
import functools
import json
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING

import sqlalchemy as sa

from daq.data_dir import default_database_path
from daq.store.faults import guard_engine
from daq.store.schema import metadata

if TYPE_CHECKING:  # alembic is imported only when a database needs migrating (or asked)
    from alembic.config import Config

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"


def default_database_url() -> str:
    """``$RIG_DATABASE_URL`` if set, else SQLite at :func:`default_database_path`."""
    url = os.environ.get("RIG_DATABASE_URL", "").strip()
    if url:
        return url
    return f"sqlite:///{default_database_path()}"


#: JSON columns keep text as written (ü, not \u00fc), so a metadata search finds it.
_json_text = functools.partial(json.dumps, ensure_ascii=False)


#: SQLite's busy wait on every connection the store opens, ms: how long a statement waits
#: for another connection's lock before it fails with "database is locked".
SQLITE_BUSY_MS = 10_000


def _set_sqlite_pragmas(dbapi_connection, _record) -> None:
    cursor = dbapi_connection.cursor()
    try:
        # the busy timeout first: switching a new file to WAL waits for the lock of a process
        # migrating it, which under load can hold it past the driver's default 5 s
        cursor.execute(f"PRAGMA busy_timeout={SQLITE_BUSY_MS:d}")
        cursor.execute("PRAGMA journal_mode=WAL")
        cursor.execute("PRAGMA synchronous=NORMAL")
        cursor.execute("PRAGMA foreign_keys=ON")
    finally:
        cursor.close()


def _create_private(path: Path) -> None:
    """Create the folder (0700 if new) and an empty database file readable by its owner
    only (0600); SQLite gives its ``-wal`` and ``-shm`` files the database file's mode. An
    existing file keeps the mode it has."""
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    with contextlib.suppress(FileExistsError):  # it exists: its mode stays
        os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600))


def shared_by_processes(url: str) -> bool:
    """Can another process open the database at ``url``? (Not an in-memory SQLite.)"""
    return not (url.startswith("sqlite") and (":memory:" in url or url.rstrip("/") == "sqlite:"))


def create_engine(url: str) -> sa.Engine:
    """An engine for ``url``; SQLite gets WAL, synchronous=NORMAL, foreign keys and a
    busy timeout, and the folder of its file is created; a new database file is private
    to its owner (0600, with its -wal and -shm files). Its storage failures are raised as
    ``daq.store.faults.StorageUnavailable`` (``guard_engine``)."""
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
            _create_private(Path(database).expanduser())
        engine = sa.create_engine(
            parsed, connect_args={"check_same_thread": False}, json_serializer=_json_text
        )
        sa.event.listen(engine, "connect", _set_sqlite_pragmas)
        return guard_engine(engine)
    if parsed.get_backend_name() == "postgresql":
        engine = sa.create_engine(parsed, pool_pre_ping=True, json_serializer=_json_text)
        return guard_engine(engine)
    raise ValueError(
        f"database URL {url!r}: backend {parsed.get_backend_name()!r} is not supported; "
        "use sqlite:/// or postgresql+psycopg://"
    )


def alembic_config(connection: sa.Connection | None = None) -> Config:
    """An Alembic Config pointing at the packaged revisions (no ini file)."""
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS_DIR).replace("%", "%%"))
    if connection is not None:
        config.attributes["connection"] = connection
    return config


def head_revision() -> str:
    """The newest revision shipped with this package."""
    from alembic.script import ScriptDirectory

    head = ScriptDirectory.from_config(alembic_config()).get_current_head()
    assert head is not None
    return head


def current_revision(engine: sa.Engine) -> str | None:
    """The revision the database is at (None for an empty database)."""
    from alembic.runtime.migration import MigrationContext

    with engine.connect() as connection:
        return MigrationContext.configure(connection).get_current_revision()


_REVISION = re.compile(r'^revision(?:: [^=]+)? = "([^"]+)"', re.M)
_DOWN_REVISION = re.compile(r'^down_revision(?:: [^=]+)? = "([^"]+)"', re.M)


@functools.cache
def _shipped_head() -> str | None:
    """The head revision read from the revision files' ``revision``/``down_revision``
    lines (None if that is not one clear head: then Alembic decides)."""
    revisions: set[str] = set()
    parents: set[str] = set()
    for path in (MIGRATIONS_DIR / "versions").glob("*.py"):
        text = path.read_text(encoding="utf-8")
        revision, parent = _REVISION.search(text), _DOWN_REVISION.search(text)
        if revision is None:
            return None
        revisions.add(revision.group(1))
        parents |= {parent.group(1)} if parent else set()
    heads = revisions - parents
    return heads.pop() if len(heads) == 1 else None


def _at_shipped_head(engine: sa.Engine) -> bool:
    """Whether the database's ``alembic_version`` is the shipped head, read with plain SQL
    so opening an up-to-date database does not import Alembic (~0.3 s of start-up)."""
    head = _shipped_head()
    if head is None:
        return False
    try:
        with engine.connect() as connection:
            versions = connection.exec_driver_sql("SELECT version_num FROM alembic_version")
            return [row[0] for row in versions] == [head]
    except sa.exc.DBAPIError:  # no table yet: a new database
        return False


#: Alembic's version table as its migration context creates it
#: (``alembic.ddl.impl.DefaultImpl.version_table_impl``), for a database made at head
#: without Alembic; tests/store/test_fresh_database.py compares it with Alembic's.
_alembic_version = sa.Table(
    "alembic_version",
    sa.MetaData(),
    sa.Column("version_num", sa.String(32), nullable=False),
    sa.PrimaryKeyConstraint("version_num", name="alembic_version_pkc"),
)


def _stored_versions(connection: sa.Connection, tables: set[str]) -> list[str]:
    """The revisions in ``alembic_version`` (none without the table, or in the table a
    downgrade to base leaves empty)."""
    if _alembic_version.name not in tables:
        return []
    return list(connection.execute(sa.select(_alembic_version.c.version_num)).scalars())


def _create_at_head(connection: sa.Connection, head: str) -> None:
    """Make a new database the shipped head's schema in one go: the tables of
    ``daq.store.schema`` (what the revisions build, tests/store/test_fresh_database.py) and
    ``alembic_version`` at ``head``, in the caller's transaction. The revisions insert no
    rows into an empty database and create nothing the metadata does not describe (no
    views, triggers or sequences of their own), so nothing else is left to do."""
    metadata.create_all(connection, checkfirst=False)
    _alembic_version.create(connection, checkfirst=True)
    connection.execute(sa.insert(_alembic_version).values(version_num=head))


def upgrade_to_head(engine: sa.Engine) -> None:
    """Bring the database to the shipped head in one transaction (a no-op when already
    there): a new database gets the head schema directly, without Alembic (importing it and
    running its 7 revisions one by one cost a new SQLite database 0.43 s of CPU more than
    opening one at head, now 0.07 s: bench/fresh_database.py); one at an older revision
    runs the pending revisions with Alembic."""
    if _at_shipped_head(engine):
        return
    head = _shipped_head()
    with engine.begin() as connection:
        # Serialise concurrent first opens of the same database (a CLI and a service, or a
        # test reading the run a `rig tow` is creating): the second waits for the first's
        # lock, then finds the schema it wrote and has nothing left to do.
        if connection.dialect.name == "postgresql":
            connection.exec_driver_sql("SELECT pg_advisory_xact_lock(74657273)")
        elif connection.dialect.name == "sqlite":
            connection.exec_driver_sql("BEGIN IMMEDIATE")  # the write lock, busy_timeout waits
        tables = set(sa.inspect(connection).get_table_names())
        versions = _stored_versions(connection, tables)
        if head is not None and versions == [head]:
            return  # another process brought it to head while this one waited
        if head is not None and not versions and not tables & set(metadata.tables):
            _create_at_head(connection, head)  # a new database
            return
        # An older revision (or tables of ours without one, or no clear shipped head):
        # Alembic's to migrate, or to refuse as it always has.
        from alembic import command

        command.upgrade(alembic_config(connection), "head")
