"""Database errors in a sentence: which ones a retry can cure, and a one-line message
(no SQL, no parameters, no blobs) for the operator, the job and the run's reason."""

from __future__ import annotations

import errno
from dataclasses import dataclass

import sqlalchemy as sa

#: SQLite result codes a later attempt can succeed at (another writer holds the lock).
_SQLITE_RETRYABLE = {"SQLITE_BUSY", "SQLITE_LOCKED"}
#: PostgreSQL SQLSTATE classes a later attempt can succeed at: connection lost (08),
#: serialization failure / deadlock (40), lock not available (55), server shutting down (57).
_PG_RETRYABLE_CLASSES = {"08", "40", "55", "57"}


#: How long a run's last samples and its end are retried against a database that
#: delays them (a held lock, a dropped connection) before they go to the spill file, s.
STORE_RETRY_S = 30.0


class StorageFault(RuntimeError):
    """Samples or a run's end could not be stored; the message is one line."""


@dataclass(frozen=True)
class StorageError:
    """What went wrong, in one line, and whether retrying may help."""

    message: str
    retryable: bool


def _first_line(text: str) -> str:
    line = text.strip().splitlines()[0] if text.strip() else ""
    return line.strip() or "unknown error"


def describe(exc: BaseException) -> StorageError:
    """Classify a database error (SQLAlchemy-wrapped or raw DB-API) in one line.

    Retryable: a lock held by another connection, a dropped connection. Not retryable
    (a fault): a full disk, an I/O error, a read-only or corrupt database, and anything
    unknown.
    """
    orig: BaseException = exc
    if isinstance(exc, sa.exc.DBAPIError) and exc.orig is not None:
        orig = exc.orig
    if isinstance(exc, sa.exc.DBAPIError) and exc.connection_invalidated:
        return StorageError(f"database connection lost: {_first_line(str(orig))}", True)
    name = getattr(orig, "sqlite_errorname", None)
    if name is not None:
        return StorageError(f"SQLite: {_first_line(str(orig))}", name in _SQLITE_RETRYABLE)
    sqlstate = getattr(orig, "sqlstate", None)
    if isinstance(sqlstate, str) and sqlstate:
        message = f"PostgreSQL: {_first_line(str(orig))}"
        return StorageError(message, sqlstate[:2] in _PG_RETRYABLE_CLASSES)
    if type(orig).__module__.startswith("psycopg") and type(orig).__name__ == "OperationalError":
        return StorageError(f"PostgreSQL: {_first_line(str(orig))}", True)  # no server reply
    if isinstance(orig, OSError):
        why = "disk full" if orig.errno == errno.ENOSPC else (orig.strerror or str(orig))
        return StorageError(f"file system: {why}", False)
    return StorageError(f"{type(orig).__name__}: {_first_line(str(orig))}", False)


def one_line(exc: BaseException) -> str:
    """The one-line message of any error; database errors lose their SQL and parameters."""
    if isinstance(exc, sa.exc.SQLAlchemyError | OSError) or hasattr(exc, "sqlite_errorname"):
        return describe(exc).message
    text = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    return text or type(exc).__name__
