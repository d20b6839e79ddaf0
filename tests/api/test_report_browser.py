"""A finished estimation on the Estimation page in real headless Chromium: the report
figures are shown full-size (a PNG of at least 1000 px filling the card, click to enlarge
to the window)
and the same figure's SVG names its axes with units."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, completed_tows, estimate_in_page, signed_in_page

# a browser page: the slow lane; its two tows on the simulated rig (paced service)
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_estimation_page_shows_full_size_report_figures_with_units(chromium, client, service):
    from playwright.sync_api import expect

    runs = completed_tows(client, (24.5, 83.3))
    with signed_in_page(chromium, service, client) as page:
        estimate_in_page(page, runs, timeout_ms=120_000)

        fit = page.locator("#est-plots figure").first
        expect(fit.locator("figcaption")).to_contain_text("fit")
        page.wait_for_function(
            "() => document.querySelector('#est-plots figure img')?.naturalWidth >= 1000"
        )
        shown = fit.locator("img").evaluate("img => img.getBoundingClientRect().width")
        card = page.locator("#est-plots").evaluate("el => el.getBoundingClientRect().width")
        assert shown >= 0.95 * card  # the figure fills the result card, not a thumbnail
        svg = fit.locator("a.report-svg").evaluate("a => fetch(a.href).then((r) => r.text())")
        for label in ("position [m]", "time from release [s]", "residual ["):
            assert label in svg
        for run in runs:  # runs labelled "run 1 (a1b2c3d4), +24.5 N", not by UUID
            assert run not in svg and f"({run[:8]})" in svg
        assert "+24.5 N" in svg and "+83.3 N" in svg

        # a click opens it over the page as large as the window allows, never cropped (the
        # PNG is wider than the window); Escape closes it
        fit.locator("img").click()
        big = page.locator("#lightbox img")
        expect(big).to_be_visible()
        width, height, natural, window_w, window_h = big.evaluate(
            "img => { const r = img.getBoundingClientRect();"
            " return [r.width, r.height, img.naturalWidth, innerWidth, innerHeight]; }"
        )
        assert natural > window_w  # the figure is larger than the window: it is scaled
        assert width <= window_w and height <= window_h, (width, height, window_w, window_h)
        assert width >= 0.9 * window_w or height >= 0.9 * (window_h - 32)  # and fills it
        page.keyboard.press("Escape")
        expect(page.locator("#lightbox")).to_be_hidden()

        # Two redraws racing (a job update and its result arrive together): the figures stay
        # once each, in the report's order.
        result = client.get("/api/results?kind=estimation", headers=AUTH).json()[0]
        page.evaluate(
            "id => import('/static/estimation.js')"
            ".then((m) => Promise.all([m.showReportPlots(id), m.showReportPlots(id)]))",
            result["id"],
        )
        # (a redraw the stream started meanwhile may still be fetching: wait for the page
        # to settle on its figures, then check there is each once, in order)
        expect(page.locator("#est-plots figcaption")).to_have_count(len(result["report_plots"]))
        captions = page.locator("#est-plots figcaption").all_inner_texts()
        assert [c.split(" — ")[0] for c in captions] == result["report_plots"]
