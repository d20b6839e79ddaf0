"""The Thrusters page in real headless Chromium shows an imported thrust-stand table as the
calibration in force (named ``imported N (file)``, with its supply once, its current and
its efficiency in g/W as a thrust stand prints it), and lists every calibration, measured
and imported; at 1366 × 768 it shows each thruster's RPM, current, supply and power live
during a calibration's sweep, and drives one thruster by hand: arm, start, watch it turn,
stop, and it is back at zero, disarmed. The rig runs in process on simulated time."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import urlencode

import pytest

from tests.api.conftest import (
    AUTH,
    how_it_ended,
    signed_in_page,
    start_job,
    wait_job,
    wait_rig_free,
)
from tests.support.shared_data import shared_file

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]

LAPTOP = {"width": 1366, "height": 768}
#: Where the journeys leave their screenshots (looked at by hand, not compared).
SHOTS = Path("/tmp/stand-shots")
#: A sweep long enough to watch (each step held 2 s of the rig's time).
SLOW_SWEEP = {"commands": [0.0, 0.2, 0.4, 0.8], "settle_s": 2.0, "samples_per_step": 10}
#: A reading of a thruster that turns / draws power: not zero, not "—".
TURNING = re.compile(r"^-?[1-9][\d.]* rpm$")
POWERED = re.compile(r"^-?(0\.\d*[1-9]|[1-9][\d.]*) W$")

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


def _live_row(page, thruster: int):
    return page.locator("#stand-live-table tbody tr").nth(thruster - 1).locator("td")


def test_rpm_current_and_power_are_live_during_a_sweep(chromium, client, service):
    from playwright.sync_api import expect

    wait_rig_free(client)
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size(LAPTOP)
        page.click("nav a[data-page=thrusters]")
        job_id = start_job(client, "/api/jobs/calibration", SLOW_SWEEP)
        row = _live_row(page, 1)
        expect(row.nth(2)).to_have_text(TURNING)
        expect(row.nth(3)).to_have_text(re.compile(r"^[\d.]+ A$"))
        expect(row.nth(4)).to_have_text(re.compile(r"^1\d\.\d V$"))  # the supply, to 0.1 V
        expect(row.nth(5)).to_have_text(POWERED)
        expect(_live_row(page, 2).nth(2)).to_have_text(TURNING)
        plot = page.locator("#stand-live-plot")  # the last minute's RPM and power
        expect(plot.locator(".main-svg").first).to_be_visible()
        expect(plot).to_contain_text("thruster 1 RPM [rpm]")
        expect(plot).to_contain_text("thruster 2 power [W]")
        SHOTS.mkdir(exist_ok=True)
        page.screenshot(path=str(SHOTS / "thrusters-sweep-1366.png"))
        job_end = wait_job(client, job_id, timeout_s=120)
        assert job_end["state"] == "completed", how_it_ended(job_end)


def test_one_thruster_by_hand_armed_started_watched_and_stopped(chromium, client, service):
    from playwright.sync_api import expect

    wait_rig_free(client)
    client.post("/api/rig/disarm", headers=AUTH)
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size(LAPTOP)
        page.click("nav a[data-page=thrusters]")
        start = page.locator("#manual-start")
        expect(start).to_be_disabled()
        expect(page.locator("#manual-reason")).to_have_text(
            "The thrusters are disarmed: arm them first (Arm thrusters)."
        )
        expect(page.locator("#manual-limits")).to_contain_text("command -0.8 … 0.8")
        expect(page.locator("#manual-command")).to_have_attribute("max", "0.8")
        page.click("#manual-arm")
        expect(start).to_be_enabled()
        expect(page.locator("#manual-reason")).to_have_text("")
        page.select_option("#manual-thruster", "2")
        page.fill("#manual-command", "0.5")
        page.fill("#manual-duration", "50")
        start.click()
        status = page.locator("#manual-status")
        expect(status).to_contain_text(
            re.compile(r"^Running: thruster 2 at \+0\.500: \d+\.\d s left$")
        )
        expect(_live_row(page, 2).nth(2)).to_have_text(TURNING)
        expect(_live_row(page, 2).nth(5)).to_have_text(POWERED)
        expect(_live_row(page, 1).nth(1)).to_have_text("0")  # the other thruster stays at zero
        page.screenshot(path=str(SHOTS / "thrusters-manual-1366.png"))
        page.click("#manual-stop")
        expect(status).to_have_text(
            "Manual run aborted: operator abort (API). Thrusters at zero, brake on."
        )
        expect(page.locator("#manual-reason")).to_contain_text("disarmed: arm them first")
    rig = client.get("/api/rig", headers=AUTH).json()
    assert rig["armed"] is False and rig["thrusters"]["output"] == [0.0, 0.0], rig["thrusters"]
    assert rig["sample"]["channels"]["tow_release"] == 0.0  # the brake engaged
