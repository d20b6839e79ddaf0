"""POST /api/runs/import of a drive logged per sample and of a pendulum decay: stored as
the estimator needs them, bad columns a one-line 422 naming the query parameter."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.api.conftest import AUTH
from tests.integration.test_import_kinds import _tow_csv

CSV = {"Content-Type": "text/csv"}


def test_the_api_imports_a_logged_drive(client, tmp_path: Path) -> None:
    _tow_csv(tmp_path / "tow.csv", 30.0, 4)
    body = (tmp_path / "tow.csv").read_bytes()
    url = "/api/runs/import?kind=tow&drive_column=pull%20(kgf)&drive_unit=kgf&release_time_s=1"
    r = client.post(url, content=body, headers=AUTH | CSV)
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["parameters"]["drive_channel"] == "drive_force"
    assert run["parameters"]["drive_unit"] == "kgf" and "force_n" not in run["parameters"]
    assert "drive_force" in run["channel_names"]

    r = client.post(url.replace("pull%20(kgf)", "pull"), content=body, headers=AUTH | CSV)
    assert r.status_code == 422
    assert r.json()["detail"].startswith("drive_column: no column 'pull' in")
    r = client.post(url + "&force_n=3", content=body, headers=AUTH | CSV)
    assert r.status_code == 422
    assert (
        r.json()["detail"] == "force_n: not used with drive_column (the drive is logged per sample)"
    )


@pytest.mark.parametrize(
    ("query", "detail"),
    [
        ("&force_n=3", "force_n: not used by a pendulum free decay (it has no drive)"),
        ("&drive_column=t", "drive_column: not used by a pendulum free decay (it has no drive)"),
    ],
)
def test_a_pendulum_import_takes_no_drive(client, query, detail) -> None:
    body = b"t,position\n0,0.1\n0.1,0.09\n"
    r = client.post(f"/api/runs/import?kind=pendulum{query}", content=body, headers=AUTH | CSV)
    assert r.status_code == 422 and r.json()["detail"] == detail


def test_the_api_imports_a_pendulum_decay_with_the_services_rig(client) -> None:
    lines = ["t,position"] + [f"{k / 10:.1f},{0.2 * 0.97**k:.5f}" for k in range(60)]
    r = client.post("/api/runs/import?kind=pendulum&filename=decay.csv",
                    content="\n".join(lines).encode(), headers=AUTH | CSV)  # fmt: skip
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["kind"] == "pendulum" and run["channel_names"] == ["pendulum_angle"]
    assert run["vehicle"] == "BENBAM"


def test_a_tow_and_a_spin_estimated_together_are_a_422_not_a_failed_job(client) -> None:
    """Two axes cannot share one fit: the request is refused before a job is made."""
    tow = "t,position\n" + "".join(f"{k / 10:.1f},{0.01 * k * k:.4f}\n" for k in range(40))
    ids = []
    for kind, drive in (("tow", "force_n=20"), ("spin", "torque_nm=2")):
        body = tow.encode()  # the same motion read as metres or radians
        r = client.post(f"/api/runs/import?kind={kind}&{drive}", content=body, headers=AUTH | CSV)
        assert r.status_code == 201, r.text
        ids.append(r.json()["run_id"])
    jobs_before = len(client.get("/api/jobs", headers=AUTH).json())
    r = client.post("/api/jobs/estimation", json={"run_ids": ids}, headers=AUTH)
    assert r.status_code == 422, r.text
    assert "run_ids: got mixed kinds ['spin', 'tow']" in r.text
    assert len(client.get("/api/jobs", headers=AUTH).json()) == jobs_before


def test_a_multipart_upload_imports_like_a_raw_body(client) -> None:
    """As ``curl -F file=@tow.csv`` sends it: the file part is the CSV (it was read as the
    CSV itself, and the multipart boundary quoted as 'the header'); the part's file name
    is the run's source file."""
    body = "t,position\n" + "".join(f"{k / 10:.1f},{0.002 * k * k:.4f}\n" for k in range(40))
    r = client.post(
        "/api/runs/import?kind=tow&force_n=20",
        files={"file": ("lab tow 3.csv", body.encode(), "text/csv")},
        headers=AUTH,
    )
    assert r.status_code == 201, r.text
    run = client.get(f"/api/runs/{r.json()['run_id']}", headers=AUTH).json()
    assert run["sample_count"] == 40 and run["source_file"] == "lab_tow_3.csv"
    r = client.post(
        "/api/runs/import?kind=tow&force_n=20",
        files={"a": ("a.csv", b"t,position\n", "text/csv"), "b": ("b.csv", b"x", "text/csv")},
        headers=AUTH,
    )
    assert r.status_code == 422 and "file: a multipart upload needs one file field" in r.text


def test_excel_semicolons_decimal_commas_and_a_bom_import_like_a_plain_csv(client) -> None:
    """The run import reads what the thrust-stand import reads (one reader): a table Excel
    saved in a decimal-comma locale gives the same samples as the plain CSV."""
    rows = [(k / 10, 0.002 * k * k) for k in range(40)]
    plain = "t,position\n" + "".join(f"{t:.1f},{x:.4f}\n" for t, x in rows)
    excel = "\ufefft;position\r\n" + "".join(
        f"{t:.1f};{x:.4f}\r\n".replace(".", ",") for t, x in rows
    )
    samples = []
    for body in (plain, excel):
        r = client.post(
            "/api/runs/import?kind=tow&force_n=20", content=body.encode(), headers=AUTH | CSV
        )
        assert r.status_code == 201, r.text
        got = client.get(f"/api/runs/{r.json()['run_id']}/samples", headers=AUTH).json()
        samples.append((got["t"], got["channels"]["tow_position"]))
    assert samples[0] == samples[1] and samples[0][1][-1] == 0.002 * 39 * 39
