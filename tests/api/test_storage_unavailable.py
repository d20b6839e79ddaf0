"""The store's boundary over HTTP: a database that cannot be reached is 503 naming it (its
URL, password masked) on every route that reads it, never a 500 with a traceback; paging
bounds are one declaration (422 naming ``offset``/``limit``); and a start while the disk a
run would be stored on is full is refused at submission (503), not accepted and failed."""

from __future__ import annotations

import logging
import socket
from collections.abc import Iterator

import pytest

from api.core.paging import MAX_OFFSET
from daq.store.migrate import create_engine
from tests.api.conftest import AUTH, SHORT_TOW, wait_rig_free

pytestmark = pytest.mark.simtime

#: Every read route that needs the database, one per store the service reads through.
READS = ("/api/rig", "/api/runs", "/api/jobs", "/api/users", "/api/rig/events")


@pytest.fixture
def database_down(service) -> Iterator[str]:
    """The service's store pointed at a PostgreSQL server that is not there (a port bound
    and never listening: connections are refused); its masked URL as messages name it."""
    with socket.socket() as closed:
        closed.bind(("127.0.0.1", 0))
        port = closed.getsockname()[1]
        store = service.store
        working = store.engine
        store.engine = create_engine(f"postgresql+psycopg://rig:secret@127.0.0.1:{port}/labdb")
        try:
            yield f"postgresql+psycopg://rig:***@127.0.0.1:{port}/labdb"
        finally:
            store.engine.dispose()
            store.engine = working


def test_every_read_route_says_503_naming_the_database_when_it_is_down(
    client, database_down, caplog
):
    caplog.set_level(logging.WARNING)
    for path in READS:
        r = client.get(path, headers=AUTH)
        assert r.status_code == 503, (path, r.status_code, r.text)
        detail = r.json()["detail"]
        assert detail.startswith(f"database {database_down} unavailable: PostgreSQL:"), detail
        assert "secret" not in detail and "\n" not in detail and "SELECT" not in detail
    assert not [rec for rec in caplog.records if rec.exc_info], "a traceback was logged"
    assert "secret" not in caplog.text


def test_a_start_while_the_database_is_down_is_refused_at_once(client, database_down):
    r = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH)
    assert r.status_code == 503, r.text
    assert r.json()["detail"].startswith(f"database {database_down} unavailable")


@pytest.mark.parametrize(
    "query",
    [
        f"offset={2**63 - 1}",
        f"offset={MAX_OFFSET + 1}",
        "offset=-1",
        "limit=0",
        f"limit={2**63 - 1}",
    ],
)
@pytest.mark.parametrize("path", ["/api/jobs", "/api/runs"])
def test_paging_out_of_range_is_422_naming_the_parameter(client, path, query):
    r = client.get(f"{path}?{query}", headers=AUTH)
    assert r.status_code == 422, (path, query, r.status_code, r.text)
    (problem,) = r.json()["errors"]
    name, value = query.split("=")
    assert (problem["field"], str(problem["value"])) == (name, value)
    assert problem["message"].startswith(f"{name}: {value!r} is not allowed")


def test_a_start_while_the_disk_is_full_is_refused_at_submission(client, monkeypatch):
    wait_rig_free(client)
    before = client.get("/api/jobs", headers=AUTH).json()
    monkeypatch.setenv("RIG_MIN_FREE_BYTES", str(2**62))  # more than any disk has free
    r = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH)
    monkeypatch.delenv("RIG_MIN_FREE_BYTES")
    assert r.status_code == 503, r.text
    detail = r.json()["detail"]
    assert detail.startswith("storage full (SQLite rig.db): the folder of SQLite rig.db has ")
    assert detail.endswith(
        f" bytes free, under the {2**62} bytes a run needs; free some space first"
    )
    assert "/" not in detail.split(":", 1)[1]  # no host path
    assert client.get("/api/jobs", headers=AUTH).json() == before  # nothing accepted
