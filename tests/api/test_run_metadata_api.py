"""Runs you can find and annotate over the API: metadata at start and after, filters by
drive, source, tag and text, local calendar days, paging with a total."""

from __future__ import annotations

from datetime import datetime, timedelta

import pytest

from tests.api.conftest import AUTH, SHORT_TOW, how_it_ended, start_job, wait_job

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py): the
#: runs' metadata is what is tested, and a real-time tow on a loaded test process can lose
#: samples to its own late simulated PLC and end aborted, as the product must.
pytestmark = [pytest.mark.simtime, pytest.mark.usefixtures("imports_in_a_thread")]

META = {"operator": "Åsa", "water_temperature_c": 18.5, "tags": ["fins-v2"], "ballast": "B3"}


def _runs(client, query: str = "") -> list[dict]:
    r = client.get(f"/api/runs?{query}", headers=AUTH)
    assert r.status_code == 200, r.text
    return r.json()


def _upload(client, name: str) -> str:
    r = client.post(
        f"/api/runs/import?kind=tow&force_n=10&filename={name}",
        content="t,position\n0,0\n0.1,0.01\n0.2,0.03\n",
        headers=AUTH | {"Content-Type": "text/csv"},
    )
    assert r.status_code == 201, r.text
    return r.json()["run_id"]


def test_a_tow_started_with_metadata_stores_it_and_is_found_by_it(client):
    job = wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW | {"metadata": META}))
    assert job["state"] == "completed", how_it_ended(job)
    run_id = job["run_ids"][0]
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    origin = {"started_by": "default", "job_id": job["id"]}  # who and which job (issue 23)
    assert run["metadata"] == META | origin
    assert (run["drive"], run["source"], run["source_file"]) == ("weight", "recorded", None)

    assert [r["id"] for r in _runs(client, "tag=fins-v2")] == [run_id]
    assert [r["id"] for r in _runs(client, "search=%C3%85sa")] == [run_id]  # "Åsa", kept as ü/Å
    assert run_id in [r["id"] for r in _runs(client, "drive=weight&source=recorded")]
    assert _runs(client, "tag=fins-v2&drive=thrusters") == []

    # annotate after: replace notes, remove a key, replace tags; the cached run follows
    r = client.patch(
        f"/api/runs/{run_id}/metadata",
        json={"notes": "long fins", "ballast": None, "tags": ["repeat"]},
        headers=AUTH,
    )
    assert r.status_code == 200, r.text
    expected = {"operator": "Åsa", "water_temperature_c": 18.5, "tags": ["repeat"],
                "notes": "long fins"} | origin  # fmt: skip
    assert r.json()["metadata"] == expected
    assert client.get(f"/api/runs/{run_id}", headers=AUTH).json()["metadata"] == expected
    assert _runs(client, "tag=fins-v2") == []
    assert [r["id"] for r in _runs(client, "search=LONG%20FINS")] == [run_id]


def test_bad_metadata_is_refused_naming_the_field_before_anything_runs(client):
    too_warm = SHORT_TOW | {"metadata": {"water_temperature_c": 80}}
    r = client.post("/api/jobs/tow", json=too_warm, headers=AUTH)
    assert r.status_code == 422
    assert "metadata.water_temperature_c: 80" in r.text and "50 °C" in r.text
    assert client.get("/api/rig", headers=AUTH).json()["current_job"] is None  # nothing started
    run_id = _runs(client, "limit=1")[0]["id"]
    for body, field in (
        ({"tags": ["two words"]}, "metadata.tags[0]"),
        ({"Bad-Key": 1}, "metadata.Bad-Key"),
        ({"depth": [1, 2]}, "metadata.depth"),
        (
            {"salinity_g_kg": 50},
            "metadata.salinity_g_kg: 50.0 is not allowed; use 0 ≤ salinity_g_kg ≤ 42",
        ),
    ):
        r = client.patch(f"/api/runs/{run_id}/metadata", json=body, headers=AUTH)
        assert r.status_code == 422 and field in r.json()["detail"], r.text
    assert client.patch("/api/runs/0000dead/metadata", json={}, headers=AUTH).status_code == 404
    # a sea-water tank's salinity is a known key (the theory comparison's ρ reads it)
    r = client.patch(f"/api/runs/{run_id}/metadata", json={"salinity_g_kg": 35.165}, headers=AUTH)
    assert r.status_code == 200 and r.json()["metadata"]["salinity_g_kg"] == 35.165, r.text


def test_imported_runs_are_marked_and_keep_the_recorded_start(client):
    run_id = _upload(client, "bench_day1.csv")
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert (run["source"], run["source_file"]) == ("imported", "bench_day1.csv")
    assert run["imported_at"] is not None and run["drive"] is None
    assert [r["id"] for r in _runs(client, "source=imported&search=bench_day1")] == [run_id]
    assert run_id not in [r["id"] for r in _runs(client, "source=recorded")]


def test_since_and_until_are_local_days_both_included(client):
    run_id = _upload(client, "today.csv")  # no t_wall column: started now
    started = datetime.fromisoformat(_runs(client, "source=imported&limit=1")[0]["started_at"])
    for tz in ("Pacific/Kiritimati", "Pacific/Pago_Pago", "UTC", "%2B05:30"):
        today = client.get(f"/api/runs?since=today&until=today&tz={tz}", headers=AUTH)
        assert run_id in [r["id"] for r in today.json()], tz
    day = started.astimezone().date().isoformat()  # this machine's day of the start
    offset = started.astimezone().strftime("%z")
    tz = f"{offset[:3]}:{offset[3:]}".replace("+", "%2B")
    assert run_id in [r["id"] for r in _runs(client, f"since={day}&until={day}&tz={tz}")]
    before = (started.astimezone().date() - timedelta(days=1)).isoformat()
    assert run_id not in [r["id"] for r in _runs(client, f"until={before}&tz={tz}")]
    exact = started.isoformat().replace("+", "%2B")
    assert run_id in [r["id"] for r in _runs(client, f"since={exact}&until={exact}")]
    bad = client.get("/api/runs?since=yesterday-ish", headers=AUTH)
    assert bad.status_code == 422 and "since: 'yesterday-ish'" in bad.text
    bad = client.get("/api/runs?tz=Mars/Olympus", headers=AUTH)
    assert bad.status_code == 422 and "tz: 'Mars/Olympus'" in bad.text


def test_runs_are_paged_with_a_total(client):
    for i in range(3):
        _upload(client, f"page{i}.csv")
    total = client.get("/api/runs?limit=1", headers=AUTH).headers["X-Total-Count"]
    seen, offset = [], 0
    while offset is not None:
        r = client.get(f"/api/runs?limit=2&offset={offset}", headers=AUTH)
        assert r.headers["X-Total-Count"] == total
        seen += [run["id"] for run in r.json()]
        nxt = r.headers.get("X-Next-Offset")
        offset = int(nxt) if nxt is not None else None
    assert len(seen) == len(set(seen)) == int(total) >= 3
    r = client.get("/api/runs?search=page&limit=2", headers=AUTH)
    assert r.headers["X-Total-Count"] == "3" and r.headers["X-Next-Offset"] == "2"


def test_an_import_takes_metadata_from_query_parameters(client):
    csv = '# metadata: {"operator": "Bo", "notes": "from the file", "ballast": "B3"}\n'
    csv += "t,position\n0,0\n0.1,0.01\n0.2,0.03\n"
    headers = AUTH | {"Content-Type": "text/csv"}
    query = "kind=tow&force_n=10&filename=annotated.csv"
    meta = ("operator=Grace&water_temperature_c=12.5&salinity_g_kg=35&tag=fins-v2&tag=repeat"
            "&meta=depth_m=1.5&meta=ballast=B4")  # fmt: skip
    r = client.post(f"/api/runs/import?{query}&{meta}", content=csv, headers=headers)
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    # the query parameters replace the file's keys they name; the file's others stay
    expected = {"operator": "Grace", "notes": "from the file", "ballast": "B4", "depth_m": 1.5,
                "water_temperature_c": 12.5, "salinity_g_kg": 35.0,
                "tags": ["fins-v2", "repeat"]}  # fmt: skip
    assert run["metadata"] == expected
    assert [x["id"] for x in _runs(client, "tag=repeat&source=imported")] == [run["id"]]

    before = client.get("/api/runs?limit=1", headers=AUTH).headers["X-Total-Count"]
    for bad, field in (("water_temperature_c=80", "water_temperature_c: '80'"),
                       ("tag=two%20words", "tag: 'two words'"),
                       ("meta=novalue", "meta: 'novalue' is not allowed; use KEY=VALUE"),
                       ("meta=Bad=1", "meta Bad: this key is not allowed")):  # fmt: skip
        r = client.post(f"/api/runs/import?{query}&{bad}", content=csv, headers=headers)
        assert r.status_code == 422 and r.json()["detail"].startswith(field), r.text
    assert client.get("/api/runs?limit=1", headers=AUTH).headers["X-Total-Count"] == before


def test_a_reverse_tow_imports_over_the_api_with_its_negative_force(client):
    r = client.post(
        "/api/runs/import?kind=tow&force_n=-24.5&weight_kg=2.5&filename=back.csv",
        content="t,position\n0,5.4\n0.1,5.39\n0.2,5.37\n",
        headers=AUTH | {"Content-Type": "text/csv"},
    )
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["force_n"] == -24.5 and run["parameters"]["hung_mass_kg"] == 2.5
    zero = client.post(
        "/api/runs/import?kind=tow&force_n=0",
        content="t,position\n0,0\n0.1,0.01\n",
        headers=AUTH | {"Content-Type": "text/csv"},
    )
    assert zero.status_code == 422 and "force_n: 0.0 is not allowed" in zero.text, zero.text
