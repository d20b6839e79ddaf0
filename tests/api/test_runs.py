"""Run reads (filters, paged samples, streamed CSV, events) and CSV import."""

from __future__ import annotations

import csv

import pytest

from tests.api.conftest import AUTH

pytestmark = pytest.mark.usefixtures("imports_in_a_thread")


def test_list_runs_filters_by_kind_status_vehicle_and_date(client, tow_job):
    run_id = tow_job["run_ids"][0]
    ids = [r["id"] for r in client.get("/api/runs?kind=tow", headers=AUTH).json()]
    assert run_id in ids
    assert client.get("/api/runs?kind=spin", headers=AUTH).json() == []
    done = client.get("/api/runs?status=completed&vehicle=BENBAM", headers=AUTH).json()
    assert run_id in [r["id"] for r in done]
    assert client.get("/api/runs?vehicle=other", headers=AUTH).json() == []
    assert client.get("/api/runs?since=2999-01-01T00:00:00Z", headers=AUTH).json() == []
    assert run_id in [
        r["id"] for r in client.get("/api/runs?until=2999-01-01", headers=AUTH).json()
    ]
    bad = client.get("/api/runs?status=exploded", headers=AUTH)
    assert bad.status_code == 422
    assert bad.json()["errors"][0]["field"] == "status"
    assert client.get("/api/runs?limit=0", headers=AUTH).status_code == 422


def test_run_by_unique_prefix_and_with_rig_file(client, tow_job):
    run_id = tow_job["run_ids"][0]
    run = client.get(f"/api/runs/{run_id[:8]}?include_toml=true", headers=AUTH).json()
    assert run["id"] == run_id
    assert "[rig]" in run["rig_toml"]
    # how it ended and what it lost (a busy machine may skip a slot: it is said, not hidden)
    lost = run["samples_lost"]
    assert run["summary"] == "completed" + (f", {lost}" if lost else "")


def test_samples_are_paged_and_pages_join_up(client, tow_job):
    run_id = tow_job["run_ids"][0]
    whole = client.get(f"/api/runs/{run_id}/samples?limit=100000", headers=AUTH).json()
    assert whole["next_start_seq"] is None
    seqs, start = [], 0
    while start is not None:
        page = client.get(
            f"/api/runs/{run_id}/samples?start_seq={start}&limit=7", headers=AUTH
        ).json()
        assert page["count"] <= 7
        seqs += page["seq"]
        start = page["next_start_seq"]
    assert seqs == whole["seq"]
    assert whole["t"][0] == 0.0
    assert whole["count"] == len(whole["channels"]["tow_position"])


def test_csv_export_streams_every_sample(client, tow_job):
    run_id = tow_job["run_ids"][0]
    r = client.get(f"/api/runs/{run_id}/samples.csv", headers=AUTH)
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/csv")
    lines = r.text.splitlines()
    assert any(line.startswith("# units: t=s,") and "tow_position=m" in line for line in lines)
    rows = list(csv.DictReader(line for line in lines if not line.startswith("#")))
    samples = client.get(f"/api/runs/{run_id}/samples?limit=100000", headers=AUTH).json()
    assert [int(row["seq"]) for row in rows] == samples["seq"]
    # written at the encoder's resolution (10 µm): the stored double, without float noise
    last = samples["channels"]["tow_position"][-1]
    assert float(rows[-1]["tow_position"]) == pytest.approx(last, abs=1e-12)


def test_events_record_release_and_brake(client, tow_job):
    events = client.get(f"/api/runs/{tow_job['run_ids'][0]}/events", headers=AUTH).json()
    actions = [(e["data"] or {}).get("action") for e in events]
    assert "release" in actions and "brake" in actions
    assert client.get(f"/api/runs/{tow_job['run_ids'][0]}/results", headers=AUTH).json() == []


def _upload(client, text: str | bytes, **params):
    query = "&".join(f"{k}={v}" for k, v in params.items())
    return client.post(
        f"/api/runs/import?{query}",
        content=text,
        headers=AUTH | {"Content-Type": "text/csv"},
    )


def test_csv_import_makes_a_completed_run(client):
    text = "t,position\n" + "".join(f"{i / 10},{0.01 * i * i / 100}\n" for i in range(50))
    r = _upload(client, text, kind="tow", force_n=24.5, weight_kg=2.5, vehicle="imported-1")
    assert r.status_code == 201, r.text
    run_id = r.json()["run_id"]
    assert r.json()["samples"] == 50
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["status"] == "completed"
    assert run["vehicle"] == "imported-1"
    assert run["parameters"]["force_n"] == 24.5


def test_bad_csv_is_422_naming_line_and_column(client):
    r = _upload(client, "t,position\n0,0\n0.1,abc\n", kind="tow", force_n=5, filename="mine.csv")
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "line 3" in detail and "position'" in detail and detail.startswith("mine.csv")
    assert "/tmp" not in detail
    r = _upload(client, "t,position\n0,0\n", kind="tow")
    assert r.status_code == 422
    assert "force_n" in r.json()["detail"]
    r = _upload(client, "t,position\n0,0\n", kind="tow", force_n=0)
    assert r.status_code == 422
    r = _upload(client, b"\xff\xfe\x00", kind="tow", force_n=3)
    assert r.status_code == 422


def test_csv_import_time_unit_and_window_fields(client):
    text = "t,position\n" + "".join(f"{i * 100},{0.001 * i * i}\n" for i in range(50))
    r = _upload(client, text, kind="tow", force_n=24.5, filename="ms.csv")
    assert r.status_code == 422
    detail = r.json()["detail"]
    assert "column 't': median step 100 between samples, expected seconds" in detail
    assert "time_unit=ms" in detail and "/tmp" not in detail
    r = _upload(client, text, kind="tow", force_n=24.5, time_unit="ms", end_time_s=7)
    assert r.status_code == 422 and "end_time_s: 7.0 is not allowed" in r.json()["detail"]
    r = _upload(
        client, text, kind="tow", force_n=24.5, time_unit="ms", release_time_s=0.4, end_time_s=4
    )
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["release_time_s"] == 0.4
    assert run["parameters"]["end_time_s"] == 4.0


def test_oversized_upload_is_413(client):
    big = "t,position\n" + "0.0,0.0\n" * 20_000  # > 64 KiB, the test app's limit
    r = _upload(client, big, kind="tow", force_n=5)
    assert r.status_code == 413
    assert "limit" in r.json()["detail"]


def test_results_and_calibration_when_none_exist(client):
    assert client.get("/api/results?kind=calibration", headers=AUTH).json() == []
    r = client.get("/api/calibration/latest", headers=AUTH)
    assert r.status_code == 404
    assert "calibration" in r.json()["detail"]
