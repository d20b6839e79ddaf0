"""The ORM description (daq/store/schema.py) and the Alembic revisions describe the same
database: autogenerate's diff between the metadata and a database migrated by running every
revision from empty is empty, on SQLite and PostgreSQL. A column added to one and not the
other fails here. (A new database opened by the store is made from the metadata directly,
not by the revisions: tests/store/test_fresh_database.py compares the two in full.)"""

from __future__ import annotations

import sqlalchemy as sa
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext

from daq.store.migrate import create_engine, current_revision, head_revision
from daq.store.schema import metadata
from tests.store.helpers import migrate_by_revisions


def _diff(engine: sa.Engine) -> list:
    with engine.connect() as connection:
        context = MigrationContext.configure(
            connection, opts={"compare_type": True, "compare_server_default": True}
        )
        return compare_metadata(context, metadata)


def test_migrated_database_matches_the_schema_module(db_url: str) -> None:
    engine = create_engine(db_url)
    try:
        migrate_by_revisions(engine)
        assert current_revision(engine) == head_revision()
        assert _diff(engine) == []
    finally:
        engine.dispose()


def test_the_comparison_sees_a_drifted_column(db_url: str) -> None:
    """The check can fail: a column the migrations never created shows up in the diff."""
    engine = create_engine(db_url)
    try:
        migrate_by_revisions(engine)
        with engine.begin() as connection:
            connection.execute(sa.text("ALTER TABLE rigs ADD COLUMN stray INTEGER"))
        diff = _diff(engine)
        assert [(d[0], d[3].name) for d in diff] == [("remove_column", "stray")]
    finally:
        engine.dispose()
