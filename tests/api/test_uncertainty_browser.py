"""A finished tow estimation on the Estimation page in real headless Chromium shows each
coefficient's value ± U in a summary table and its budget table (declared Type B rows, the
dominant source)."""

from __future__ import annotations

import pytest

from tests.api.conftest import completed_tows, estimate_in_page, signed_in_page

pytestmark = pytest.mark.simtime  # its two tows on the simulated rig (paced service)


def test_estimation_page_shows_the_uncertainty_budget(chromium, client, service):
    from playwright.sync_api import expect

    runs = completed_tows(client, (24.5, 44.1, 83.3))
    with signed_in_page(chromium, service, client) as page:
        estimate_in_page(page, runs, timeout_ms=120_000)
        table = page.locator("#est-uncertainty table.est-budget[data-coefficient='inertia']")
        expect(table).to_contain_text("hung_mass_kg")
        expect(table).to_contain_text("g_m_s2")
        # three runs resample: the bootstrap is a row of the budget and a column beside σ
        expect(table).to_contain_text("bootstrap over runs")
        expect(page.locator("#est-coefs thead")).to_contain_text("Bootstrap σ")
        expect(page.locator("#est-coefs tbody tr").first.locator("td").nth(3)).to_contain_text("± ")
        head = page.locator("#est-uncertainty h4.est-budget-head").first
        expect(head).to_contain_text("inertia = ")
        expect(head).to_contain_text("dominant:")
        expect(page.locator("#est-uncertainty")).to_contain_text("k = 1.96")
        # read first: one summary row per quantity, value ± U and its dominant source
        summary = page.locator(
            "#est-uncertainty table.est-budget-summary tr[data-quantity='inertia']"
        )
        expect(summary).to_contain_text("±")
        expect(summary).to_be_visible()
