"""The Thrusters page in real headless Chromium shows an imported thrust-stand table as the
calibration in force (named ``imported N (file)``, with its supply once, its current and
its efficiency in g/W as a thrust stand prints it), and lists every calibration, measured
and imported."""

from __future__ import annotations

from urllib.parse import urlencode

import pytest

from tests.api.conftest import AUTH, signed_in_page
from tests.support.shared_data import shared_file

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = pytest.mark.slow

QUERY = {
    "command_column": "PWM (µs)",
    "command_unit": "pwm_us",
    "thrust_column": "Force (Kg f)",
    "thrust_unit": "kgf",
    "voltage_column": "Voltage (V)",
    "name": "T200-16V.csv",
}


def test_an_imported_table_is_shown_with_its_current_and_efficiency(chromium, client, service):

    table = shared_file("thrusters", "T200-16V.csv").read_bytes()
    r = client.post(
        f"/api/calibrations/import?{urlencode(QUERY)}",
        content=table,
        headers=AUTH | {"Content-Type": "text/csv"},
    )
    assert r.status_code == 201, r.text
    label = f"imported {r.json()['id']} (T200-16V.csv)"
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=thrusters]")
        _shows(page, label)


def _shows(page, label: str) -> None:
    from playwright.sync_api import expect

    expect(page.locator("#cal-status")).to_contain_text(f"Newest calibration: {label}")
    expect(page.locator("#cal-status")).to_contain_text("at 16.0 V.")
    rows = page.locator("#cal-table tbody tr")
    expect(rows).to_have_count(201)
    # The last row is full forward: 23.83 A, 51.44 N / 381.28 W = 0.1349 N/W = 13.76 g/W.
    last = rows.last.locator("td")
    expect(last.nth(4)).to_have_text("23.83")
    expect(last.nth(6)).to_have_text("381.3")
    expect(last.nth(7)).to_have_text("13.8")
    listed = page.locator("#cal-list tbody tr").first.locator("td")
    expect(listed.nth(0)).to_have_text(label)
    expect(listed.nth(1)).to_have_text("imported")
    expect(listed.nth(5)).to_contain_text("current_a, rpm, power_w, efficiency_n_per_w")
