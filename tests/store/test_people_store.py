"""Users and the safety log in the database (SQLite and PostgreSQL): a token is stored only
as its hash and found by it; the safety log's latest event of a pair is the rig's state;
a database of revision 0005 with a job upgrades to 0006 with that job unnamed."""

from __future__ import annotations

import json

import pytest
import sqlalchemy as sa

from daq.store import Store
from daq.store.migrate import alembic_config, create_engine, current_revision, head_revision
from daq.store.people_and_safety_log import (
    ESTOP,
    ESTOP_ACK,
    HOLD,
    RELEASE,
    RigEventLog,
    User,
    UserExists,
    UserRepository,
    token_hash,
)


def test_a_token_is_kept_only_as_its_hash_and_finds_its_user(store: Store) -> None:
    users = UserRepository(store)
    token = users.add("alice", "operator")
    viewer = users.add("vic", "viewer")
    with store.engine.connect() as conn:
        stored = conn.execute(sa.text("SELECT name, token_sha256 FROM users")).all()
    assert token not in json.dumps([list(r) for r in stored])
    assert dict(stored)["alice"] == token_hash(token)
    assert users.by_token(token) == User("alice", "operator")
    assert users.by_token(viewer) == User("vic", "viewer") and not users.by_token(viewer).operator
    assert users.by_token(token + "x") is None
    with pytest.raises(UserExists, match="user 'alice' exists"):
        users.add("alice", "viewer")
    with pytest.raises(ValueError, match="role: 'admin' is not allowed"):
        users.add("eve", "admin")
    with pytest.raises(ValueError, match="name: 'a b' is not allowed"):
        users.add("a b", "viewer")
    assert users.remove("alice") and users.by_token(token) is None
    assert [u["name"] for u in users.list()] == ["vic"]


def test_the_latest_event_of_a_pair_is_the_state_per_rig(store: Store) -> None:
    log = RigEventLog(store, "tank A")
    other = RigEventLog(store, "tank B")
    assert log.active(ESTOP, ESTOP_ACK) is None
    log.add(ESTOP, None, "emergency stop (API) (no token)")
    log.add(HOLD, "alice", "rigging")
    assert log.active(ESTOP, ESTOP_ACK)["user_name"] is None
    assert other.active(ESTOP, ESTOP_ACK) is None  # another rig's log
    log.add(ESTOP_ACK, "bob", "acknowledged")
    assert log.active(ESTOP, ESTOP_ACK) is None
    assert log.active(HOLD, RELEASE)["message"] == "rigging"
    log.add(RELEASE, "alice", "released by the holder")
    assert log.active(HOLD, RELEASE) is None
    assert [e["kind"] for e in log.recent()] == [RELEASE, ESTOP_ACK, HOLD, ESTOP]


def test_a_database_of_revision_0005_upgrades_with_its_jobs_unnamed(db_url: str) -> None:
    from alembic import command

    engine = create_engine(db_url)
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0005")
        conn.execute(
            sa.text(
                "INSERT INTO jobs (id, rig_name, kind, label, state, parameters, fraction, "
                "message, run_ids, notes, created_at) VALUES ('j1', 'old', 'tow', 'tow 5 N', "
                "'completed', '{}', 1, 'done', '[]', '[]', 1.7e9)"
            )
        )
    with Store(db_url) as store:
        assert current_revision(engine) == head_revision() != "0005"
        from daq.store.job_repository import JobRepository

        row = JobRepository(store).get("j1")
        assert (row["label"], row["user_name"]) == ("tow 5 N", None)
        assert UserRepository(store).list() == []
    engine.dispose()
