"""End to end in real headless Chromium against a real ``rig serve`` process: start a tow
from the page, see live data arrive, see the run listed and export it as NetCDF, run an
estimation, see its result."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import httpx
import pytest
import xarray as xr

from tests.api.conftest import csp_blocked
from tests.support.serve import stop_service, wait_for_service

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)

TOKEN = "browser-test-token"
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("serve")
    env = os.environ | {"RIG_API_TOKEN": TOKEN, "XDG_DATA_HOME": str(tmp), "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "api.cli.serve", "--port", "0", "--db", f"sqlite:///{tmp}/rig.db"],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        url = wait_for_service(proc)
        yield url
    finally:
        stop_service(proc)


def _clock_record(server: str) -> dict:
    """The service's account of its clock (``GET /api/rig``'s ``clock``): its skipped slots,
    late wake-ups and host stalls, for a failure's message."""
    rig = httpx.get(f"{server}api/rig", headers={"Authorization": f"Bearer {TOKEN}"}, timeout=10)
    return rig.json().get("clock") or {}


@pytest.fixture(scope="module")
def page(chromium, server):
    with chromium.page() as pg:
        yield pg


def test_tow_from_the_page_live_data_run_listed_and_estimated(server, page, tmp_path):
    from playwright.sync_api import expect

    page.goto(f"{server}#token={TOKEN}")
    expect(page.locator("#conn-text")).to_contain_text("simulated")
    assert "token=" not in page.url  # the token left the address bar

    # live samples arrive before anything runs
    page.wait_for_function("() => Number(document.querySelector('#live-count').textContent) > 5")

    # out-of-range input: the server's message names the field and the limit
    page.fill("#form-tow [name=force_n]", "")
    page.fill("#form-tow [name=weight_kg]", "")
    page.click("#start-tow")
    expect(page.locator("#form-tow .errors")).to_contain_text("force_n")

    runs = []
    for force in ("24.5", "83.3"):
        page.fill("#form-tow [name=force_n]", force)
        page.fill("#form-tow [name=max_time_s]", "2.0")
        page.fill("#form-tow [name=baseline_s]", "0.3")
        before = int(page.text_content("#live-count"))
        page.click("#start-tow")
        expect(page.locator("#job-state")).to_have_text("running")
        state = page.locator("#job-state")
        expect(state).to_have_text(re.compile("completed|aborted|failed"), timeout=30_000)
        # a tow that did not complete fails naming why (the job's box: its reason)
        assert state.text_content().strip() == "completed", page.text_content("#job-panel")
        assert int(page.text_content("#live-count")) > before + 20  # live data during the tow
        runs.append(page.text_content("#job-runs").strip())

    page.click("nav a[data-page=runs]")
    rows = page.locator("#runs-table tbody tr")
    expect(rows).to_have_count(2)
    expect(rows.first).to_contain_text("tow")
    expect(rows.first).to_contain_text("completed")
    rows.first.click()
    expect(page.locator("#run-detail-id")).to_contain_text(runs[-1])
    expect(page.locator("#run-events")).to_contain_text("brake released")

    # the export menu: the run as NetCDF, which xarray opens with units and the run's id
    page.select_option("#export-format", "netcdf")
    with page.expect_download() as download:
        page.click("#export-run")
    assert download.value.suggested_filename.endswith(".nc")
    saved = tmp_path / download.value.suggested_filename
    download.value.save_as(saved)
    with xr.open_dataset(saved) as ds:
        assert runs[-1] in ds.attrs["run_id"] and ds.attrs["kind"] == "tow"
        assert ds["tow_position"].attrs["units"] == "m" and ds.sizes["t"] > 20

    page.click("nav a[data-page=estimation]")
    boxes = page.locator("#est-runs tbody input[type=checkbox]")
    expect(boxes).to_have_count(2)
    boxes.nth(0).check()
    boxes.nth(1).check()
    page.click("#est-run")
    try:
        expect(page.locator("#est-state")).to_have_text("completed", timeout=60_000)
    except AssertionError as err:  # a refused run names its lost slots; the clock says why
        raise AssertionError(f"{err}\nthe service's clock: {_clock_record(server)}") from err
    coefs = page.locator("#est-coefs tbody tr:not(.est-known)")  # the well-determined rows aside
    expect(coefs).to_have_count(3)
    expect(page.locator("#est-coefs")).to_contain_text("inertia")
    # no effect found: no "before effects" value beside each coefficient (it would repeat it)
    expect(page.locator("#est-effects-list")).to_contain_text("none")
    expect(page.locator("#est-coefs")).not_to_contain_text("before effects")
    # two tows: too few to resample (their "spread" would be 0): no bootstrap column
    expect(page.locator("#est-coefs thead th")).to_have_count(3)
    expect(page.locator("#est-rmse")).to_contain_text("RMSE after")
    expect(page.locator("#est-plots img").first).to_be_visible(timeout=20_000)
    assert csp_blocked(page) == []  # live plot, forms, figures: the page's CSP allows them
