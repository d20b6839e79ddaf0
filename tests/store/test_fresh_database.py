"""A new database is made at the head schema in one go (``metadata.create_all`` and the head
written into ``alembic_version``, no Alembic): what it makes must be exactly what the
revisions make one by one, on SQLite and PostgreSQL — tables, columns, keys, indexes,
constraints, views, triggers, sequences and the recorded revision — and two first opens of
one database must still take turns."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from typing import Any

import pytest
import sqlalchemy as sa

from daq.store import Store
from daq.store.migrate import (
    _shipped_head,
    create_engine,
    current_revision,
    head_revision,
    upgrade_to_head,
)
from daq.store.schema import metadata
from tests.conftest import fresh_database
from tests.store.helpers import migrate_by_revisions
from tests.support.pg import PostgresServer
from tests.support.waiting import wait_until


@pytest.fixture
def other_db_url(db_url: str, request: pytest.FixtureRequest, tmp_path) -> Iterator[str]:
    """A second fresh, empty database on ``db_url``'s backend."""
    backend = "sqlite" if db_url.startswith("sqlite") else "postgresql"
    with fresh_database(backend, request, tmp_path, "other.db") as url:
        yield url


@pytest.fixture
def without_alembic(monkeypatch: pytest.MonkeyPatch) -> None:
    """Importing Alembic fails from here on: what runs took the path without it."""
    for name in [m for m in sys.modules if m == "alembic" or m.startswith("alembic.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "alembic", None)


def _column(column: dict[str, Any]) -> dict[str, Any]:
    return {**column, "type": str(column["type"])}


def _table_sql_options(connection: sa.Connection, table: str) -> tuple[bool, ...]:
    """What an SQLite table's CREATE statement says beyond its columns and constraints
    (WITHOUT ROWID, STRICT), which reflection does not report."""
    if connection.dialect.name != "sqlite":
        return ()
    sql = connection.exec_driver_sql(
        "SELECT sql FROM sqlite_master WHERE type = 'table' AND name = ?", (table,)
    ).scalar_one()
    tail = sql.rsplit(")", 1)[-1].upper()
    return ("WITHOUT ROWID" in tail, "STRICT" in tail)


def _other_objects(connection: sa.Connection) -> dict[str, list]:
    """Objects beside tables and their indexes: views, triggers, sequences (PostgreSQL),
    each by name (and table)."""
    if connection.dialect.name == "sqlite":
        rows = connection.exec_driver_sql(
            "SELECT type, name, tbl_name FROM sqlite_master WHERE type IN ('view', 'trigger') "
            "ORDER BY type, name"
        )
        return {"views_and_triggers": [tuple(r) for r in rows]}
    triggers = connection.exec_driver_sql(
        "SELECT tgrelid::regclass::text, tgname FROM pg_trigger WHERE NOT tgisinternal "
        "ORDER BY 1, 2"
    )
    functions = connection.exec_driver_sql(
        "SELECT p.proname FROM pg_proc p JOIN pg_namespace n ON n.oid = p.pronamespace "
        "WHERE n.nspname = current_schema() ORDER BY 1"
    )
    inspector = sa.inspect(connection)
    return {
        "views": sorted(inspector.get_view_names()),
        "materialized_views": sorted(inspector.get_materialized_view_names()),
        "sequences": sorted(inspector.get_sequence_names()),
        "triggers": [tuple(r) for r in triggers],
        "functions": [r[0] for r in functions],
    }


def schema_of(url: str) -> dict[str, Any]:
    """Everything the database says about its schema, and the revision it records."""
    engine = create_engine(url)
    try:
        with engine.connect() as connection:
            inspector = sa.inspect(connection)
            tables = {}
            for name in sorted(inspector.get_table_names()):
                tables[name] = {
                    "columns": [_column(c) for c in inspector.get_columns(name)],
                    "primary_key": inspector.get_pk_constraint(name),
                    "foreign_keys": sorted(
                        inspector.get_foreign_keys(name), key=lambda fk: str(fk["name"])
                    ),
                    "indexes": sorted(inspector.get_indexes(name), key=lambda i: str(i["name"])),
                    "unique": sorted(
                        inspector.get_unique_constraints(name), key=lambda u: str(u["name"])
                    ),
                    "checks": sorted(
                        inspector.get_check_constraints(name), key=lambda c: str(c["name"])
                    ),
                    "comment": (
                        inspector.get_table_comment(name)
                        if connection.dialect.supports_comments
                        else None
                    ),
                    "sql_options": _table_sql_options(connection, name),
                }
            versions = connection.exec_driver_sql("SELECT version_num FROM alembic_version")
            return {
                "tables": tables,
                "other_objects": _other_objects(connection),
                "alembic_version": [r[0] for r in versions],
            }
    finally:
        engine.dispose()


def test_a_new_database_made_at_once_equals_one_migrated_revision_by_revision(
    db_url: str, other_db_url: str, monkeypatch: pytest.MonkeyPatch, without_alembic: None
) -> None:
    engine = create_engine(db_url)
    try:
        upgrade_to_head(engine)  # Alembic cannot be imported: the direct path, or a failure
    finally:
        engine.dispose()
    made_at_once = schema_of(db_url)

    monkeypatch.undo()  # Alembic back, for the revisions
    engine = create_engine(other_db_url)
    try:
        migrate_by_revisions(engine)
    finally:
        engine.dispose()
    migrated = schema_of(other_db_url)

    assert made_at_once == migrated
    assert set(migrated["tables"]) == {*metadata.tables, "alembic_version"}
    assert migrated["alembic_version"] == [head_revision()]


@pytest.mark.parametrize(
    "extra",
    [
        "CREATE INDEX ix_stray ON runs (reason)",
        "CREATE VIEW stray_runs AS SELECT id FROM runs",
        "ALTER TABLE rigs ADD COLUMN stray INTEGER",
    ],
)
def test_the_schema_comparison_sees_an_object_made_on_one_side_only(
    db_url: str, other_db_url: str, extra: str
) -> None:
    """The comparison above can fail: one index, view or column more on one side shows."""
    for url in (db_url, other_db_url):
        Store(url).close()
    assert schema_of(db_url) == schema_of(other_db_url)
    engine = create_engine(other_db_url)
    try:
        with engine.begin() as connection:
            connection.exec_driver_sql(extra)
    finally:
        engine.dispose()
    assert schema_of(db_url) != schema_of(other_db_url)


def test_the_revisions_insert_no_rows_into_a_new_database(db_url: str) -> None:
    """Made at once, a new database has no rows but its revision: the revisions, run one by
    one, must leave none either (a row they insert would be missing on the direct path)."""
    engine = create_engine(db_url)
    try:
        migrate_by_revisions(engine)
        with engine.connect() as connection:
            counts = {
                name: connection.execute(sa.select(sa.func.count()).select_from(table)).scalar()
                for name, table in metadata.tables.items()
            }
    finally:
        engine.dispose()
    assert counts == dict.fromkeys(metadata.tables, 0)


def test_a_database_downgraded_to_base_is_made_at_head_again(db_url: str) -> None:
    """A downgrade to base leaves ``alembic_version`` empty and none of the tables: opening
    it is a first open (the direct path writes its revision into the table that stays)."""
    from alembic import command

    from daq.store.migrate import alembic_config

    Store(db_url).close()
    engine = create_engine(db_url)
    try:
        with engine.begin() as connection:
            command.downgrade(alembic_config(connection), "base")
        assert current_revision(engine) is None
        upgrade_to_head(engine)
        assert current_revision(engine) == head_revision()
    finally:
        engine.dispose()
    assert set(schema_of(db_url)["tables"]) == {*metadata.tables, "alembic_version"}


def waiting(connection: sa.Connection) -> int:
    """How many connections to this PostgreSQL database wait for an advisory lock."""
    return connection.exec_driver_sql(
        "SELECT count(*) FROM pg_locks WHERE locktype = 'advisory' AND NOT granted "
        "AND database = (SELECT oid FROM pg_database WHERE datname = current_database())"
    ).scalar_one()


def test_two_first_opens_of_one_postgresql_database_take_turns(
    postgres_server: PostgresServer, without_alembic: None
) -> None:
    """Two stores open one empty database while a third connection holds the migration's
    advisory lock: both wait for it; once it is released one makes the schema and the other
    finds it at head (without the lock the second would fail on "relation already
    exists", or, finding tables but no revision, hand it to Alembic, which is not here)."""
    url = postgres_server.create_database()
    holder = sa.create_engine(url)
    opened: list[Store | BaseException] = []

    def open_it() -> None:
        try:
            opened.append(Store(url))
        except BaseException as err:  # shown by the assertion below
            opened.append(err)

    openers = [threading.Thread(target=open_it) for _ in range(2)]
    try:
        with holder.connect() as connection:
            held = connection.begin()
            connection.exec_driver_sql("SELECT pg_advisory_xact_lock(74657273)")
            for opener in openers:
                opener.start()
            wait_until(lambda: waiting(connection) == 2, "both opens waiting for the lock")
            held.commit()
        for opener in openers:
            opener.join(60)
        assert len(opened) == 2 and all(isinstance(s, Store) for s in opened), opened
        assert schema_of(url)["alembic_version"] == [_shipped_head()]
    finally:
        for store in opened:
            if isinstance(store, Store):
                store.close()
        holder.dispose()
        postgres_server.drop_database(url)
