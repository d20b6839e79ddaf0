"""Stored results a lab can find again: the list filtered by run, vehicle, kind and date and
paged in the database, the comparison of results side by side, and a result's report as one
zip (report.md, the figures and result.json)."""

from __future__ import annotations

import io
import json
import math
import zipfile

import pytest

from tests.api.conftest import AUTH, completed_tows, how_it_ended, start_job, wait_job
from tests.store.helpers import new_run

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime


def _estimate(value_a: float, std_a: float, budget_u: float | None = None) -> dict:
    """A result document with two coefficients; a budget for inertia when ``budget_u``."""
    doc: dict = {
        "axis": "surge",
        "method": "output-error",
        "units": {"inertia": "kg", "linear_damping": "kg/s"},
        "coefficients": {
            "inertia": {"value": value_a, "std": std_a},
            "linear_damping": {"value": 3.0, "std": 0.5},
        },
    }
    if budget_u is not None:
        inertia = {"expanded_uncertainty": budget_u, "combined_standard_uncertainty": budget_u / 2}
        doc["budget"] = {"coefficients": {"inertia": inertia}}
    return doc


@pytest.fixture(scope="module")
def stored(service, client) -> dict:
    """Three runs of two vehicles and three results made from them, and a thrust
    calibration recorded on the simulated rig (ids by name)."""
    store = service.store
    body = {"commands": [0.3, 0.6, 0.8], "settle_s": 0.1, "samples_per_step": 2, "tare_samples": 3}
    calibration = wait_job(client, start_job(client, "/api/jobs/calibration", body))
    assert calibration["state"] == "completed", how_it_ended(calibration)
    alpha = new_run(store, vehicle="ALPHA-<b>")
    alpha2 = new_run(store, vehicle="ALPHA-<b>")
    beta = new_run(store, vehicle="BETA")
    return {
        "alpha": alpha,
        "beta": beta,
        "a": store.add_result([alpha], "estimation", _estimate(10.0, 1.0)),
        "b": store.add_result([alpha, alpha2], "estimation", _estimate(13.0, 1.0, budget_u=4.0)),
        "c": store.add_result([beta], "estimation", _estimate(10.5, 0.1)),
        "cal": calibration["outcome"]["calibration"]["result_id"],
        "cal_run": calibration["run_ids"][0],
    }


def _ids(response) -> list[int]:
    assert response.status_code == 200, response.text
    return [r["id"] for r in response.json()]


def test_results_are_filtered_and_paged_in_the_database(client, stored):
    mine = {stored[k] for k in ("a", "b", "c", "cal")}
    listed = client.get("/api/results?limit=500", headers=AUTH)
    newest_first = [stored["c"], stored["b"], stored["a"], stored["cal"]]
    assert [i for i in _ids(listed) if i in mine] == newest_first
    run = client.get(f"/api/results?run={stored['alpha'][:8]}", headers=AUTH)
    assert _ids(run) == [stored["b"], stored["a"]]
    assert run.headers["X-Total-Count"] == "2"
    vehicle = client.get("/api/results", params={"vehicle": "BETA"}, headers=AUTH)
    assert _ids(vehicle) == [stored["c"]]
    kind = client.get("/api/results?kind=calibration", headers=AUTH)
    assert stored["cal"] in _ids(kind) and not {stored[k] for k in "abc"} & set(_ids(kind))
    of_run = client.get(f"/api/results?run={stored['cal_run']}", headers=AUTH)
    assert _ids(of_run) == [stored["cal"]]
    assert _ids(client.get(f"/api/results?run={stored['cal_run']}&kind=estimation",
                           headers=AUTH)) == []  # fmt: skip
    page = client.get("/api/results?vehicle=ALPHA-<b>&limit=1&offset=0", headers=AUTH)
    assert _ids(page) == [stored["b"]]
    assert page.headers["X-Total-Count"] == "2" and page.headers["X-Next-Offset"] == "1"
    last = client.get("/api/results?vehicle=ALPHA-<b>&limit=1&offset=1", headers=AUTH)
    assert _ids(last) == [stored["a"]] and "X-Next-Offset" not in last.headers
    since = client.get("/api/results?vehicle=BETA&since=2000-01-01&until=today", headers=AUTH)
    assert _ids(since) == [stored["c"]]
    future = client.get("/api/results?vehicle=BETA&since=2999-01-01", headers=AUTH)
    assert _ids(future) == [] and future.headers["X-Total-Count"] == "0"


@pytest.mark.parametrize(
    ("query", "field"),
    [("limit=0", "limit"), ("limit=501", "limit"), ("offset=-1", "offset"),
     ("offset=1000001", "offset"), ("since=yesterdayish", "since"), ("kind=magic", "kind")],
)  # fmt: skip
def test_bad_paging_and_filters_are_422_naming_the_field(client, query, field):
    r = client.get(f"/api/results?{query}", headers=AUTH)
    assert r.status_code == 422, r.text
    assert field in r.text


def test_unknown_run_and_result_are_404_naming_the_id(client, stored):
    r = client.get("/api/results?run=feedf00d", headers=AUTH)
    assert r.status_code == 404 and "feedf00d" in r.text
    for path in ("/api/results/987654", "/api/results/987654/report.zip",
                 f"/api/results/compare?ids={stored['a']},987654"):  # fmt: skip
        r = client.get(path, headers=AUTH)
        assert r.status_code == 404, (path, r.text)
        assert "987654" in r.json()["detail"]


def test_compare_gives_value_U_and_the_difference_in_sigma(client, stored):
    r = client.get(f"/api/results/compare?ids={stored['a']},{stored['b']},{stored['c']}",
                   headers=AUTH)  # fmt: skip
    assert r.status_code == 200, r.text
    cmp = r.json()
    assert [x["id"] for x in cmp["results"]] == [stored["a"], stored["b"], stored["c"]]
    assert cmp["reference"] == stored["a"]
    inertia = next(row for row in cmp["coefficients"] if row["coefficient"] == "inertia")
    assert inertia["unit"] == "kg"
    a, b, c = inertia["cells"]
    assert (c["U"], c["U_from"]) == (pytest.approx(0.2), "2σ")
    assert (a["U"], a["U_from"]) == (2.0, "2σ")  # no budget: 2σ
    assert (b["U"], b["U_from"], b["sigma"]) == (4.0, "budget", 2.0)  # the budget's U and u_c
    d_b, d_c = inertia["difference_sigma"][1:]
    assert inertia["difference_sigma"][0] is None
    assert d_b == pytest.approx(3.0 / math.sqrt(1.0 + 4.0))
    assert d_c == pytest.approx(0.5 / math.sqrt(1.0 + 0.01))


@pytest.mark.parametrize("ids", ["1", "1,1", "1,x", "", "1,2,3,4,5,6,7,8,9,10,11,12,13"])
def test_compare_refuses_bad_ids_naming_them(client, ids):
    r = client.get(f"/api/results/compare?ids={ids}", headers=AUTH)
    assert r.status_code == 422, r.text
    assert "ids" in r.text


def test_report_zip_holds_report_md_figures_and_result_json(client):
    runs = completed_tows(client, (24.5, 83.3))
    r = client.post("/api/jobs/estimation", json={"run_ids": runs}, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)
    assert job["state"] == "completed", how_it_ended(job)
    result_id = job["result_id"]
    stored = client.get(f"/api/results/{result_id}", headers=AUTH).json()
    assert stored["report_plots"] == ["fit", "force_residual"]  # report.md is no figure
    got = client.get(f"/api/results/{result_id}/report.zip", headers=AUTH)
    assert got.status_code == 200 and got.headers["content-type"] == "application/zip"
    assert f'filename="result-{result_id}-report.zip"' in got.headers["content-disposition"]
    archive = zipfile.ZipFile(io.BytesIO(got.content))
    folder = f"result-{result_id}-report/"
    names = sorted(n.removeprefix(folder) for n in archive.namelist())
    assert names == ["fit.png", "fit.svg", "force_residual.png", "force_residual.svg",
                     "report.md", "result.json"]  # fmt: skip
    markdown = archive.read(folder + "report.md").decode()
    assert "fit.png" in markdown and "inertia" in markdown
    assert archive.read(folder + "fit.png").startswith(b"\x89PNG")
    assert json.loads(archive.read(folder + "result.json")) == stored
    listed = client.get(f"/api/runs/{runs[0]}/results", headers=AUTH).json()
    assert result_id in [x["id"] for x in listed]
