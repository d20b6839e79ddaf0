"""The Cross-check page in real headless Chromium: compare two stored estimation results,
then tick runs as weight / thrusters and run the estimation + cross-check job."""

from __future__ import annotations

import re

import pytest

from api.core.crosscheck_job import crosscheck_results
from api.core.estimation_job import run_estimation
from api.http.app import create_app
from tests.api.conftest import TOKEN, LiveServer
from tests.procedures.test_crosscheck_cli import _import_tows

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def page_url(chromium, client, service, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("csv")
    first = _import_tows(service.store, tmp, (24.5, 83.3), seed=1)
    second = _import_tows(service.store, tmp, (14.7, 63.7), seed=2)  # K_L, K_Q separable
    one_level = _import_tows(service.store, tmp, (44.1,), seed=3)
    results = [
        run_estimation(service.store, ids)["result_id"] for ids in (first, second, one_level)
    ]
    # What the page must show: a row per compared coefficient (and combined damping)
    rows = {
        pair: len(doc["coefficients"]) + len(doc.get("combined") or {})
        for pair in ((0, 1), (0, 2))
        for doc in [crosscheck_results(service.store, results[pair[0]], results[pair[1]])]
    }
    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, chromium.page() as pg:
        yield pg, live.url, results, first, second, rows


def test_crosscheck_page_compares_results_and_runs(page_url, tmp_path):
    from playwright.sync_api import expect

    page, url, results, first, second, expected = page_url
    page.goto(f"{url}/#token={TOKEN}")
    page.click("nav a[data-page=crosscheck]")
    expect(page.locator(f"#cc-weight option[value='{results[0]}']")).to_have_count(1)
    page.select_option("#cc-weight", str(results[0]))
    page.select_option("#cc-thrusters", str(results[1]))
    page.click("#cc-compare")
    # the comparison and its figure are made in the niced analysis worker process (never the
    # rig's): on a loaded box that takes seconds, while the page says "Comparing…"
    expect(page.locator("#cc-result")).to_be_visible(timeout=60_000)
    rows = page.locator("#cc-table tbody tr")
    assert expected[(0, 1)] >= 3  # inertia, K_L, K_Q at least
    expect(rows).to_have_count(expected[(0, 1)])
    expect(rows.first).to_contain_text("inertia (kg)")
    expect(page.locator("#cc-title")).to_contain_text(f"weight result #{results[0]}")
    expect(page.locator("#cc-diagnosis li").first).to_be_visible()
    expect(page.locator("#cc-kv")).to_contain_text("Common factor")
    expect(page.locator("#cc-plot .main-svg").first).to_be_visible()

    # One tow cannot separate K_L from K_Q: no verdict on them, the damping at its speed
    # compared instead.
    page.select_option("#cc-thrusters", str(results[2]))
    page.click("#cc-compare")
    expect(page.locator("#cc-title")).to_contain_text(
        f"thruster result #{results[2]}", timeout=60_000
    )
    expect(rows).to_have_count(expected[(0, 2)])
    expect(rows.nth(1)).to_contain_text("undecided")
    expect(rows.nth(1).locator("td.verdict")).to_have_attribute("title", re.compile("one drive"))
    expect(rows.last).to_contain_text(re.compile(r"K_L \+ K_Q·\|v\| at \|v\| = \S+ m/s \(N·s/m\)"))
    expect(page.locator("#cc-plot .gtitle")).to_contain_text("relative to the weight-driven value")
    page.set_viewport_size({"width": 1366, "height": 768})
    page.screenshot(path=str(tmp_path / "crosscheck-undecided.png"), full_page=True)

    for run in first:
        page.check(f"#cc-runs input[name=cc-w][value='{run}']")
    for run in second:
        page.check(f"#cc-runs input[name=cc-t][value='{run}']")
    page.click("#cc-estimate")
    expect(page.locator("#cc-state")).to_have_text("completed", timeout=90_000)
    expect(page.locator("#cc-kv")).to_contain_text("Stored as result")
    expect(page.locator("#cc-table tbody tr").first).to_contain_text("inertia (kg)")
