"""Opening a database: migrations to head, SQLite pragmas, the default location."""

from __future__ import annotations

import json

import sqlalchemy as sa

from daq.store import Store, default_database_url
from daq.store.migrate import (
    alembic_config,
    create_engine,
    current_revision,
    head_revision,
    upgrade_to_head,
)

TABLES = {"rigs", "vehicles", "runs", "sample_blocks", "events", "results", "result_runs"}


def test_opening_an_empty_database_upgrades_it_to_head(db_url: str) -> None:
    engine = create_engine(db_url)
    assert current_revision(engine) is None
    assert not TABLES & set(sa.inspect(engine).get_table_names())

    Store(db_url).close()

    inspector = sa.inspect(engine)
    assert set(inspector.get_table_names()) >= TABLES
    assert current_revision(engine) == head_revision()
    block_columns = [c["name"] for c in inspector.get_columns("sample_blocks")]
    assert block_columns == [
        "run_id",
        "first_seq",
        "last_seq",
        "sample_count",
        "level",
        "t_wall_max",
        "stale",
        "seq",
        "t_mono",
        "t_wall",
        "quality",
        "channel_values",
    ]
    primary_key = inspector.get_pk_constraint("sample_blocks")["constrained_columns"]
    assert primary_key == ["run_id", "first_seq"]
    assert "samples" not in inspector.get_table_names()  # one row per sample is gone
    engine.dispose()


def test_reopening_keeps_data_and_downgrade_upgrade_round_trips(db_url: str) -> None:
    from alembic import command

    with Store(db_url) as store:
        run_id = store.create_run(
            kind="tow",
            parameters={},
            channel_names=["tow_position"],
            rig_name="r",
            vehicle="v",
            rig_toml="",
        )
    with Store(db_url) as store:  # second open: no migration to run, data intact
        assert store.get_run(run_id).status == "running"

    engine = create_engine(db_url)
    with engine.begin() as conn:
        command.downgrade(alembic_config(conn), "base")
    assert not TABLES & set(sa.inspect(engine).get_table_names())
    upgrade_to_head(engine)
    assert set(sa.inspect(engine).get_table_names()) >= TABLES
    engine.dispose()


def test_sqlite_runs_in_wal_mode_with_synchronous_normal(tmp_path) -> None:
    with Store(f"sqlite:///{tmp_path / 'rig.db'}") as store, store.engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        assert conn.exec_driver_sql("PRAGMA synchronous").scalar() == 1  # NORMAL
        assert conn.exec_driver_sql("PRAGMA foreign_keys").scalar() == 1
    assert (tmp_path / "rig.db-wal").exists() or (tmp_path / "rig.db").exists()


def test_default_url_is_env_var_else_xdg_data_home(monkeypatch, tmp_path) -> None:
    monkeypatch.setenv("RIG_DATABASE_URL", "postgresql+psycopg://lab@db/rig")
    assert default_database_url() == "postgresql+psycopg://lab@db/rig"

    monkeypatch.delenv("RIG_DATABASE_URL")
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    expected = tmp_path / "data" / "towrig" / "rig.db"
    assert default_database_url() == f"sqlite:///{expected}"
    with Store() as store:  # creates the folder and the database
        assert store.integrity_check() == "ok"
    assert expected.exists()

    monkeypatch.delenv("XDG_DATA_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert default_database_url() == f"sqlite:///{tmp_path}/home/.local/share/towrig/rig.db"


def test_unsupported_url_names_the_backend() -> None:
    import pytest

    with pytest.raises(ValueError, match="'mysql' is not supported"):
        Store("mysql://lab@db/rig")
    with pytest.raises(ValueError, match="not valid"):
        Store("not a url")


def test_a_database_at_the_first_revision_upgrades_with_its_runs(db_url: str) -> None:
    from alembic import command

    engine = create_engine(db_url)
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0001")
        rig_id = conn.execute(sa.text("INSERT INTO rigs (name) VALUES ('old') RETURNING id"))
        rig_id = rig_id.scalar_one()
        conn.execute(sa.text("INSERT INTO vehicles (id, name) VALUES (1, 'v')"))
        conn.execute(
            sa.text(
                "INSERT INTO runs (uuid, kind, status, parameters, rig_id, vehicle_id, "
                "started_at, channel_names, sample_count, software_version, rig_toml, owner_pid) "
                "VALUES ('0123abcd-0000-4000-8000-000000000000', 'tow', 'running', '{}', :rig, "
                "1, 1.7e9, '[\"tow_position\"]', 0, '0.0.1', '', 1)"
            ),
            {"rig": rig_id},
        )
    assert current_revision(engine) == "0001"
    with Store(db_url) as store:
        assert current_revision(engine) == head_revision() != "0001"
        run = store.get_run("0123abcd")
        assert (run.kind, run.status, run.rig_name, run.channel_names) == (
            "tow",
            "running",
            "old",
            ("tow_position",),
        )
    engine.dispose()


def test_the_quick_head_check_reads_the_same_head_as_alembic(db_url: str) -> None:
    """Opening an up-to-date database skips Alembic by reading the head from the revision
    files; it must be the head Alembic finds, and a database behind it is migrated."""
    from alembic import command

    from daq.store.migrate import _at_shipped_head, _shipped_head

    assert _shipped_head() == head_revision()
    engine = create_engine(db_url)
    upgrade_to_head(engine)
    assert _at_shipped_head(engine)
    with engine.begin() as conn:
        command.downgrade(alembic_config(conn), "0002")
    assert not _at_shipped_head(engine)
    upgrade_to_head(engine)
    assert current_revision(engine) == head_revision()


def test_runs_of_revision_0002_get_their_drive_and_source_from_their_parameters(
    db_url: str,
) -> None:
    from alembic import command

    engine = create_engine(db_url)
    old = {
        "0123abcd-0000-4000-8000-000000000001": ("spin", {"drive": "thrusters"}),
        "0123abcd-0000-4000-8000-000000000002": (
            "tow", {"source": "import", "file": "/data/day1.csv", "hung_mass_kg": 1.0},
        ),
        "0123abcd-0000-4000-8000-000000000003": ("pendulum", {"start_angle_rad": 0.2}),
    }  # fmt: skip
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0002")
        conn.execute(sa.text("INSERT INTO rigs (id, name) VALUES (1, 'old')"))
        conn.execute(sa.text("INSERT INTO vehicles (id, name) VALUES (1, 'v')"))
        for uuid, (kind, params) in old.items():
            conn.execute(
                sa.text(
                    "INSERT INTO runs (uuid, kind, status, parameters, rig_id, vehicle_id, "
                    "started_at, channel_names, sample_count, software_version, rig_toml) "
                    "VALUES (:uuid, :kind, 'completed', :params, 1, 1, 1.7e9, '[\"x\"]', 0, "
                    "'0.0.1', '')"
                ),
                {"uuid": uuid, "kind": kind, "params": json.dumps(params)},
            )
    with Store(db_url) as store:
        runs = {r.id: r for r in store.list_runs()}
        found = {u: (r.drive, r.source, r.source_file, r.metadata) for u, r in runs.items()}
        assert found == {
            "0123abcd-0000-4000-8000-000000000001": ("thrusters", "recorded", None, {}),
            "0123abcd-0000-4000-8000-000000000002": ("weight", "imported", "day1.csv", {}),
            "0123abcd-0000-4000-8000-000000000003": (None, "recorded", None, {}),
        }
        assert [r.kind for r in store.list_runs(drive="none")] == ["pendulum"]
    engine.dispose()
