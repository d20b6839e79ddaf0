"""The Analysis page in real headless Chromium, on the app served by real uvicorn (the
sensitivity analysis needs no rig; the real ``rig serve`` stack is test_browser.py's)."""

from __future__ import annotations

import json

import pytest

from tests.api.conftest import signed_in_page

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = pytest.mark.slow

INCONSISTENT = [[1, 5, 1 / 7], [1 / 5, 1, 7], [7, 1 / 7, 1]]


def test_analysis_page_ranks_sweeps_and_reports_ahp_errors(chromium, client, service, tmp_path):
    from playwright.sync_api import expect

    # a stored estimation result is offered under what it is of (GET /api/results' subject)
    store = service.store
    run = store.create_run(kind="tow", parameters={}, channel_names=["carriage_position"],
                           rig_name="r", vehicle="benbam", rig_toml="")  # fmt: skip
    doc = {"kind": "tow", "axis": "surge", "dof": "heave", "method": "output-error",
           "coefficients": {}, "runs": [run]}  # fmt: skip
    result_id = store.add_result([run], "estimation", doc)
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=analysis]")
        expect(page.locator("#an-vehicle option")).not_to_have_count(0)
        offered = page.locator(f"#an-estimates label:has(input[value='{result_id}'])")
        expect(offered).to_contain_text(f"#{result_id} heave tow test / output-error")
        page.select_option("#an-vehicle", "benbam")
        for name in ("steady_surge_speed", "steady_yaw_rate"):
            page.check(f"#an-responses input[value={name}]")
        page.fill("#an-form [name=thresholds]", "0.05")
        page.click("#an-form button[type=submit]")
        expect(page.locator("#an-status")).to_contain_text("simulations in", timeout=30_000)
        expect(page.locator("#an-ranking tbody tr")).to_have_count(18)
        expect(page.locator("#an-sweep tbody tr")).to_have_count(8)  # 4 thresholds × 2 criteria
        expect(page.locator("#an-ahp")).to_contain_text("equal weights")
        first = page.locator("#an-ranking tbody tr").first
        expect(first).to_contain_text("quadratic_damping")
        expect(page.locator("#an-bars .main-svg").first).to_be_attached()
        expect(page.locator("#an-stability")).to_contain_text("response's weight")
        # The plot's title is drawn (Plotly ignores a title given as a string).
        expect(page.locator("#an-bars .gtitle")).to_have_text(
            "Composite knock-out index Σ Sc·Y (%)"
        )
        page.set_viewport_size({"width": 1366, "height": 768})
        page.screenshot(path=str(tmp_path / "analysis-ranking.png"), full_page=True)

        ahp = {"name": "mine", "matrix": INCONSISTENT, "labels": ["a", "b", "c"]}
        page.fill("#an-form [name=ahp]", json.dumps(ahp))
        page.click("#an-form button[type=submit]")
        expect(page.locator("#an-status")).to_contain_text("mine: consistency ratio CR")
