"""Database errors in a sentence: which ones a retry can cure, and a one-line message
(no SQL, no parameters, no blobs) for the operator, the job and the run's reason.

The store's boundary (:func:`guard_engine`, installed on every engine the store opens)
turns a database that cannot be reached or written — a server down, a dropped
connection, a full disk, a read-only or corrupt file — into one error,
:class:`StorageUnavailable`, naming the database (a URL with its password masked, or a
SQLite file's name: never a host path), so callers catch that, not SQLAlchemy's errors.
"""

from __future__ import annotations

import errno
import re
from dataclasses import dataclass
from pathlib import Path

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


class DatabaseNotOpened(StorageFault):
    """The store could not open its database: a bad URL, a missing driver, a server that
    cannot be reached. The message is the driver's reason on one line, any URL in it
    masked (it may hold a password)."""


class StorageUnavailable(StorageFault, sa.exc.OperationalError):
    """The database named ``database`` cannot be reached or written; ``error`` says why in
    one line and whether a retry may help. Still a SQLAlchemy ``OperationalError`` (with
    the driver's error as ``orig``), so code that retries database errors goes on working."""

    def __init__(
        self, database: str, error: StorageError, orig: BaseException | None = None
    ) -> None:
        sa.exc.OperationalError.__init__(self, None, None, orig or RuntimeError(error.message))
        self.database = database
        self.error = error
        self.args = (f"database {database} unavailable: {error.message}",)

    def __str__(self) -> str:
        return str(self.args[0])

    def __reduce__(self) -> tuple:  # crosses to worker processes as itself
        return (type(self), (self.database, self.error))


class StorageFull(StorageUnavailable):
    """Less free space than a run needs (``daq.store.free_space``) in ``place``: the
    database's folder or the spill folder, named without a host path."""

    def __init__(self, database: str, place: str, free_bytes: int, min_free_bytes: int) -> None:
        message = (
            f"storage full ({database}): {place} has {free_bytes} bytes free, under the "
            f"{min_free_bytes} bytes a run needs; free some space first"
        )
        super().__init__(database, StorageError(message, False))
        self.place, self.free_bytes, self.min_free_bytes = place, free_bytes, min_free_bytes
        self.args = (message,)

    def __reduce__(self) -> tuple:
        return (type(self), (self.database, self.place, self.free_bytes, self.min_free_bytes))


@dataclass(frozen=True)
class StorageError:
    """What went wrong, in one line, and whether retrying may help."""

    message: str
    retryable: bool


def held_by_another(exc: BaseException) -> bool:
    """Whether ``exc`` is SQLite's lock held by another connection past its busy wait (a
    later attempt can succeed; a server's errors are not this)."""
    orig = exc.orig if isinstance(exc, sa.exc.DBAPIError) else exc
    return getattr(orig, "sqlite_errorname", None) in _SQLITE_RETRYABLE


def _first_line(text: str) -> str:
    line = text.strip().splitlines()[0] if text.strip() else ""
    return line.strip() or "unknown error"


def describe(exc: BaseException) -> StorageError:
    """Classify a database error (SQLAlchemy-wrapped or raw DB-API) in one line.

    Retryable: a lock held by another connection, a dropped connection. Not retryable
    (a fault): a full disk, an I/O error, a read-only or corrupt database, and anything
    unknown.
    """
    if isinstance(exc, StorageUnavailable):
        return exc.error
    orig: BaseException = exc
    if isinstance(exc, sa.exc.DBAPIError) and exc.orig is not None:
        orig = exc.orig
    if isinstance(exc, sa.exc.DBAPIError) and exc.connection_invalidated:
        return StorageError(f"database connection lost: {_first_line(str(orig))}", True)
    name = getattr(orig, "sqlite_errorname", None)
    if name is not None:
        return StorageError(f"SQLite: {_first_line(str(orig))}", held_by_another(orig))
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


#: Errors of the statement itself (a bug or a bad value), not of the storage: left as they are.
_STATEMENT_ERRORS = (
    sa.exc.IntegrityError,
    sa.exc.ProgrammingError,
    sa.exc.DataError,
    sa.exc.NotSupportedError,
)


def sqlite_file(url: sa.URL) -> Path | None:
    """The file of a SQLite URL (None: not SQLite, or in memory)."""
    name = (url.database or "").removeprefix("file:").split("?")[0]
    if url.get_backend_name() != "sqlite" or name in ("", ":memory:"):
        return None
    return Path(name).expanduser()


def database_name(url: sa.URL) -> str:
    """How messages name a database: a SQLite file by its name (no folder), a server's by
    its URL with the password masked."""
    if url.get_backend_name() == "sqlite":
        file = sqlite_file(url)
        return f"SQLite {file.name}" if file is not None else "SQLite in memory"
    return url.render_as_string(hide_password=True)


def unavailable(exc: BaseException, database: str) -> StorageUnavailable | None:
    """``exc`` as :class:`StorageUnavailable` when it is the storage failing (not the
    statement), else None."""
    if isinstance(exc, StorageUnavailable):
        return exc
    if not isinstance(exc, sa.exc.DBAPIError) or isinstance(exc, _STATEMENT_ERRORS):
        return None
    return StorageUnavailable(database, describe(exc), exc.orig)


def guard_engine(engine: sa.Engine) -> sa.Engine:
    """Install the store's boundary on ``engine``: its storage failures are raised as
    :class:`StorageUnavailable` (a connection pool's liveness probe is left alone)."""
    database = database_name(engine.url)

    def translate(context: sa.engine.ExceptionContext) -> BaseException | None:
        if context.is_pre_ping:
            return None
        return unavailable(context.sqlalchemy_exception or context.original_exception, database)

    sa.event.listen(engine, "handle_error", translate)
    return engine


def opening_reason(exc: BaseException) -> str:
    """Why a database could not be opened: the driver's reason (not SQLAlchemy's wrapper
    text, nor its help link) on one line, every URL in it shown as ``<URL>``."""
    text = str(getattr(exc, "orig", None) or exc)
    text = re.sub(r"\(Background on this error at: [^)]*\)", "", text)
    text = re.sub(r"\w+://\S*", "<URL>", text)
    return " ".join(text.split())


def sqlite_file_of(url: str) -> Path | None:
    """The file a database URL names (None: not SQLite, in memory, or not a URL the store
    can read; opening it says what is wrong)."""
    try:
        return sqlite_file(sa.make_url(url))
    except sa.exc.ArgumentError:
        return None


def shown_url(url: str) -> str:
    """A database URL as a log may show it: its password masked."""
    return sa.make_url(url).render_as_string(hide_password=True)


def one_line(exc: BaseException) -> str:
    """The one-line message of any error; database errors lose their SQL and parameters."""
    if isinstance(exc, sa.exc.SQLAlchemyError | OSError) or hasattr(exc, "sqlite_errorname"):
        return describe(exc).message
    text = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
    return text or type(exc).__name__
