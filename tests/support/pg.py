"""A throwaway PostgreSQL server for tests and CI.

``start_postgres()`` runs ``initdb`` and ``pg_ctl`` from the Debian/Ubuntu server package
(``/usr/lib/postgresql/*/bin``) or from ``$PATH`` in a temporary folder, listening only on a
unix socket inside that folder (no TCP port is taken). As root it runs them as the
``postgres`` user (initdb refuses root). ``PostgresServer.url(name)`` gives an SQLAlchemy URL.

Command line (for CI scripts)::

    python -m tests.support.pg            # runs a fresh server until Ctrl-C, printing its admin URL
"""

from __future__ import annotations

import atexit
import glob
import os
import shutil
import socket
import subprocess
import tempfile
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import sqlalchemy as sa

FAST_SETTINGS = ("fsync=off", "synchronous_commit=off", "full_page_writes=off")


def find_postgres_bin() -> Path | None:
    """The folder holding ``initdb`` and ``pg_ctl`` (newest installed version), or None."""
    candidates = sorted(
        glob.glob("/usr/lib/postgresql/*/bin/initdb"),
        key=lambda p: int(Path(p).parts[-3]) if Path(p).parts[-3].isdigit() else 0,
    )
    if candidates:
        return Path(candidates[-1]).parent
    initdb = shutil.which("initdb")
    return Path(initdb).parent if initdb else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@dataclass
class PostgresServer:
    """A running server (``admin_url`` reaches its maintenance database); ``stop()`` ends
    it and removes its folder when this object started it."""

    admin_url: str
    base_dir: Path | None = None
    bin_dir: Path | None = None
    run_as: list[str] = field(default_factory=list)
    _engine: sa.Engine | None = None
    _head_template: str | None = None

    def url(self, database: str) -> str:
        """SQLAlchemy URL of ``database`` on this server."""
        return sa.make_url(self.admin_url).set(database=database).render_as_string(False)

    def _admin(self) -> sa.Engine:
        if self._engine is None:
            self._engine = sa.create_engine(self.admin_url, isolation_level="AUTOCOMMIT")
        return self._engine

    def create_database(self, prefix: str = "towrig_test", *, at_head: bool = False) -> str:
        """Create an empty database (``at_head``: a copy of one migrated to the newest
        revision, ``CREATE DATABASE … TEMPLATE``); returns its URL."""
        name = f"{prefix}_{uuid.uuid4().hex[:12]}"
        template = self._head() if at_head else "template0"
        with self._admin().connect() as conn:
            conn.exec_driver_sql(f'CREATE DATABASE "{name}" TEMPLATE "{template}"')
        return self.url(name)

    def _head(self) -> str:
        """The name of this server's database migrated to head, made on first use (a
        template must have no connections while it is copied: the store is closed)."""
        if self._head_template is None:
            from daq.store import Store

            url = self.create_database("towrig_head")
            Store(url).close()
            self._head_template = str(sa.make_url(url).database)
        return self._head_template

    def drop_database(self, url: str) -> None:
        """Drop the database of ``url`` (closing its connections)."""
        name = sa.make_url(url).database
        with self._admin().connect() as conn:
            conn.exec_driver_sql(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')

    def stop(self) -> None:
        """Stop the server (if this object started it) and remove its folder."""
        ours = self.base_dir is not None and self.bin_dir is not None
        if not ours and self._head_template is not None:  # on a server that stays up
            self.drop_database(self.url(self._head_template))
        self._head_template = None  # (ours goes with its cluster)
        if self._engine is not None:
            self._engine.dispose()
        if self.base_dir is None or self.bin_dir is None:
            return
        subprocess.run(
            [
                *self.run_as,
                str(self.bin_dir / "pg_ctl"),
                "-D",
                str(self.base_dir / "data"),
                "-m",
                "immediate",
                "-w",
                "stop",
            ],
            capture_output=True,
            timeout=30,
        )
        shutil.rmtree(self.base_dir, ignore_errors=True)
        self.base_dir = None  # stopping twice is harmless


def start_postgres(bin_dir: Path | None = None) -> PostgresServer:
    """Start a fresh cluster in a temporary folder; raises RuntimeError with the server's
    log when it does not come up."""
    bin_dir = bin_dir or find_postgres_bin()
    if bin_dir is None:
        raise RuntimeError("PostgreSQL server binaries (initdb, pg_ctl) not found")
    base = Path(tempfile.mkdtemp(prefix="towrig-pg-"))
    run_as: list[str] = []
    if os.geteuid() == 0:
        run_as = ["runuser", "-u", "postgres", "--"]
        shutil.chown(base, "postgres", "postgres")
    data, sock, log = base / "data", base / "sock", base / "server.log"
    subprocess.run([*run_as, "mkdir", "-m", "700", str(sock)], check=True)
    port = _free_port()
    try:
        subprocess.run(
            [
                *run_as,
                str(bin_dir / "initdb"),
                "-D",
                str(data),
                "-U",
                "postgres",
                "-A",
                "trust",
                "-E",
                "UTF8",
                "--no-sync",
                "--no-instructions",
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
        options = f"-c listen_addresses='' -k {sock} -p {port} " + " ".join(
            f"-c {s}" for s in FAST_SETTINGS
        )
        subprocess.run(
            [
                *run_as,
                str(bin_dir / "pg_ctl"),
                "-D",
                str(data),
                "-l",
                str(log),
                "-o",
                options,
                "-w",
                "-t",
                "60",
                "start",
            ],
            check=True,
            capture_output=True,
            timeout=90,
        )
    except (subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
        output = getattr(exc, "stderr", b"") or b""
        server_log = log.read_text(errors="replace") if log.exists() else ""
        shutil.rmtree(base, ignore_errors=True)
        raise RuntimeError(
            f"could not start PostgreSQL from {bin_dir}: {exc}\n"
            f"{output.decode(errors='replace')}\n{server_log}"
        ) from exc
    admin_url = f"postgresql+psycopg://postgres@/postgres?host={sock}&port={port}"
    server = PostgresServer(admin_url=admin_url, base_dir=base, bin_dir=bin_dir, run_as=run_as)
    atexit.register(server.stop)  # even if the caller forgets (or pytest is interrupted)
    return server


def external_postgres(url: str) -> PostgresServer:
    """A server given by URL (e.g. ``$RIG_TEST_POSTGRES_URL``); its user must be allowed
    to create databases."""
    return PostgresServer(admin_url=url)


if __name__ == "__main__":
    import signal

    stop_signals = {signal.SIGINT, signal.SIGTERM}
    signal.pthread_sigmask(signal.SIG_BLOCK, stop_signals)
    print(start_postgres().admin_url, flush=True)  # e.g. RIG_TEST_POSTGRES_URL for another shell
    signal.sigwait(stop_signals)  # then atexit stops the server
