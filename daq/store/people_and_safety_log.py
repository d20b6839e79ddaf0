"""Named users and the rig's safety log (the SQL of ``users`` and ``rig_events``).

A user's token is made here, shown once and stored only as its SHA-256: a token is 32
random bytes (``secrets.token_urlsafe``), so a plain hash cannot be brute-forced and stays
cheap enough to check on every request (a slow KDF such as scrypt is for guessable
passwords). The safety log keeps emergency stops, their acknowledgements, holds and
releases, each naming who; the rig's state is the latest event of each pair.
"""

from __future__ import annotations

import hashlib
import re
import secrets
import time
from dataclasses import dataclass
from typing import Any

import sqlalchemy as sa

from daq.store.database import StoreBase
from daq.store.schema import USER_ROLES, rig_events, users

#: A user's name: what jobs, runs and the safety log show.
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_.-]{0,39}")
#: Event kinds of the safety log, by pair: (sets the state, clears it).
ESTOP, ESTOP_ACK = "estop", "estop_ack"
HOLD, RELEASE = "hold", "release"


def token_hash(token: str) -> str:
    """The SHA-256 (hex) a token is stored as."""
    return hashlib.sha256(token.encode()).hexdigest()


def check_user_name(name: str, field: str = "name") -> str:
    """``name`` if it is a user name; ``ValueError`` naming ``field`` and what is allowed."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ValueError(
            f"{field}: {name!r} is not allowed (allowed 1-40 letters, digits or _.- "
            "starting with a letter)"
        )
    return name


@dataclass(frozen=True)
class User:
    """Who a request or a command acts as."""

    name: str
    role: str

    @property
    def operator(self) -> bool:
        return self.role == "operator"


class UserExists(ValueError):
    pass


class UserRepository:
    """The users of one database."""

    def __init__(self, store: StoreBase) -> None:
        self.store = store

    def add(self, name: str, role: str) -> str:
        """Add a user; returns the new token (only its hash is stored)."""
        check_user_name(name)
        if role not in USER_ROLES:
            raise ValueError(f"role: {role!r} is not allowed (allowed {', '.join(USER_ROLES)})")
        token = secrets.token_urlsafe(32)
        with self.store.transaction() as conn:
            if conn.execute(sa.select(users.c.id).where(users.c.name == name)).first():
                raise UserExists(f"name: user {name!r} exists (remove it first to re-issue)")
            conn.execute(
                sa.insert(users).values(
                    name=name, role=role, token_sha256=token_hash(token), created_at=time.time()
                )
            )
        return token

    def remove(self, name: str) -> bool:
        """Remove a user (its token stops working); whether it existed."""
        with self.store.transaction() as conn:
            return conn.execute(sa.delete(users).where(users.c.name == name)).rowcount == 1

    def rotate(self, name: str) -> str | None:
        """Give user ``name`` a new token (the old one stops working at once); None when
        there is no such user."""
        token = secrets.token_urlsafe(32)
        with self.store.transaction() as conn:
            changed = conn.execute(
                sa.update(users).where(users.c.name == name).values(token_sha256=token_hash(token))
            ).rowcount
        return token if changed == 1 else None

    def list(self) -> list[dict[str, Any]]:
        """Every user (name, role, created_at), by name; never a token."""
        query = sa.select(users.c.name, users.c.role, users.c.created_at).order_by(users.c.name)
        with self.store.engine.connect() as conn:
            return [dict(r._mapping) for r in conn.execute(query)]

    def by_token(self, token: str) -> User | None:
        """The user whose token this is, or None."""
        query = sa.select(users.c.name, users.c.role).where(
            users.c.token_sha256 == token_hash(token)
        )
        with self.store.engine.connect() as conn:
            row = conn.execute(query).first()
        return None if row is None else User(row.name, row.role)

    def by_name(self, name: str) -> User | None:
        query = sa.select(users.c.name, users.c.role).where(users.c.name == name)
        with self.store.engine.connect() as conn:
            row = conn.execute(query).first()
        return None if row is None else User(row.name, row.role)


class RigEventLog:
    """The safety log of one rig."""

    def __init__(self, store: StoreBase, rig_name: str) -> None:
        self.store = store
        self.rig_name = rig_name

    def add(self, kind: str, user_name: str | None, message: str) -> dict[str, Any]:
        """Record one event; returns it."""
        row = {
            "rig_name": self.rig_name,
            "t_wall": time.time(),
            "kind": kind,
            "user_name": user_name,
            "message": message,
        }
        with self.store.transaction() as conn:
            conn.execute(sa.insert(rig_events).values(**row))
        return row

    def latest(self, *kinds: str) -> dict[str, Any] | None:
        """The newest event of one of ``kinds``, or None."""
        query = (
            sa.select(rig_events)
            .where(rig_events.c.rig_name == self.rig_name, rig_events.c.kind.in_(kinds))
            .order_by(rig_events.c.id.desc())
            .limit(1)
        )
        with self.store.engine.connect() as conn:
            row = conn.execute(query).first()
        return None if row is None else dict(row._mapping)

    def active(self, sets: str, clears: str) -> dict[str, Any] | None:
        """The event of kind ``sets`` in force (not followed by a ``clears``), or None."""
        event = self.latest(sets, clears)
        return event if event is not None and event["kind"] == sets else None

    def recent(self, limit: int = 50) -> list[dict[str, Any]]:
        """The newest events first."""
        query = (
            sa.select(rig_events)
            .where(rig_events.c.rig_name == self.rig_name)
            .order_by(rig_events.c.id.desc())
            .limit(limit)
        )
        with self.store.engine.connect() as conn:
            return [dict(r._mapping) for r in conn.execute(query)]
