"""In real headless Chromium at 1366 × 768 (issue 32): a viewer sees their own name and
role, every control that starts or changes something disabled with the reason as its
tooltip (the emergency stop stays live), who started each past job, and an emergency stop
in a technician's words; after a thrust calibration the Thrusters page reads as a thrust
stand (RPM, power, efficiency in g/W, the response time with its σ, N/kgf/lbf); a job
asked to stop shows "stopping" before the service answers."""

from __future__ import annotations

import re
import time

import pytest

from api.http.app import create_app
from daq.store.people_and_safety_log import UserRepository
from tests.api.conftest import (
    AUTH,
    TOKEN,
    LiveServer,
    completed_tows,
    how_it_ended,
    signed_in_page,
    start_job,
    wait_job,
    wait_rig_free,
)
from tests.api.test_submission_checks import QUICK_CALIBRATION

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]

LAPTOP = {"width": 1366, "height": 768}
ISO_TIME = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d")


def test_a_viewer_sees_their_name_and_disabled_controls_with_the_reason(
    chromium, client, service
) -> None:
    from playwright.sync_api import expect

    completed_tows(client, [24.5])  # a past job, started by the operator "default"
    viewer = UserRepository(service.store).add("vera", "viewer")
    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, chromium.page() as page:
        page.set_viewport_size(LAPTOP)
        page.goto(f"{live.url}/#token={viewer}")
        expect(page.locator("#who-name")).to_have_text("vera")
        expect(page.locator("#who-role")).to_have_text("viewer")
        reason = re.compile(
            r"role viewer\): starting, stopping or changing anything needs role operator"
        )
        tow = page.locator(".start-form[data-run-kind=tow] button[type=submit]")
        for button in (tow, page.locator("#arm-btn"), page.locator("#abort-btn")):
            expect(button).to_be_disabled()
            expect(button).to_have_attribute("title", reason)
        expect(page.locator("#role-note")).to_contain_text(reason)  # seen without hovering
        expect(page.locator("#estop-btn")).to_be_enabled()  # anyone may stop the rig
        page.click("nav a[data-page=thrusters]")  # the manual thrust control, the same
        for button in ("#manual-arm", "#manual-start"):
            expect(page.locator(button)).to_be_disabled()
            expect(page.locator(button)).to_have_attribute("title", reason)
        expect(page.locator("#manual-reason")).to_have_text(
            "You are signed in with role viewer: driving a thruster needs role operator."
        )
        page.click("nav a[data-page=rig]")
        status = page.locator("#status-table")
        expect(status.locator("tr", has_text="Thrusters").locator("td").nth(1)).to_have_text(
            "disarmed"
        )

        # An emergency stop: a local time, who, a button (disabled for a viewer), and the
        # status table agreeing with it; never the API route nor a raw ISO timestamp.
        assert client.post("/api/rig/emergency-stop").status_code == 200
        banner = page.locator("#estop-latched")
        expect(banner).to_contain_text("pressed")
        expect(banner).to_contain_text("refuses motion")
        rig_row = status.locator("tr", has_text="emergency stop").locator("td").nth(1)
        expect(rig_row).to_contain_text("stopped: emergency stop at")
        for text in (banner.inner_text(), rig_row.inner_text()):
            assert not ISO_TIME.search(text) and "POST" not in text, text
        expect(page.locator("#estop-ack-btn")).to_be_disabled()
        expect(page.locator("#estop-ack-btn")).to_have_attribute("title", reason)
        ack = client.post("/api/estop/ack", json={"note": "checked"}, headers=AUTH)
        assert ack.status_code == 200, ack.text
        expect(banner).to_have_count(0)

        page.click("nav a[data-page=queue]")
        row = page.locator("#history-table tbody tr").first
        expect(row.locator("td").nth(2)).to_have_text("default")
        expect(row.locator("button[data-requeue]")).to_be_disabled()


def test_the_thrusters_page_reads_as_a_thrust_stand_after_a_calibration(
    chromium, client, service
) -> None:
    from playwright.sync_api import expect

    job = wait_job(
        client, start_job(client, "/api/jobs/calibration", QUICK_CALIBRATION), timeout_s=60
    )
    assert job["state"] == "completed", how_it_ended(job)
    data = client.get("/api/calibration/latest", headers=AUTH).json()["data"]
    response = data["response"]
    strongest = max(data["table"], key=lambda r: r["thrust_per_thruster_n"])
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size(LAPTOP)
        page.click("nav a[data-page=thrusters]")
        # the supply voltage once, to 0.1 V (its range under load), not each step's reading
        supply = re.compile(r" at \d+\.\d(–\d+\.\d)? V\.$")
        expect(page.locator("#cal-status")).to_have_text(supply)
        figures = page.locator("#cal-stand-table")
        expect(figures).to_contain_text(f"RPM at largest thrust{_js(strongest['rpm'], 4)}")
        expect(figures).to_contain_text(
            f"Electrical power at largest thrust{_js(strongest['power_w'], 4)} W"
        )
        grams_per_watt = strongest["efficiency_n_per_w"] / 9.80665 * 1000
        expect(figures).to_contain_text(f"Efficiency at largest thrust{_js(grams_per_watt, 3)} g/W")
        expect(figures).to_contain_text(re.compile(r"Best efficiency \(≥ 20 % of largest thrust\)"))
        expect(figures).to_contain_text(
            f"Response time τ (first-order lag){_js(response['time_constant_s'], 3)} "
            f"± {_js(response['std_s'], 2)} s"
        )
        expect(figures).to_contain_text(f"90 % settling{_js(response['settle_90_s'], 3)} s")
        live = page.locator("#stand-live")  # the live stream's supply voltage and commands
        expect(live).to_contain_text(re.compile(r"supply voltage \d+\.\d V"))  # to 0.1 V
        first = page.locator("#stand-live-table tbody tr").first.locator("td")
        expect(first.nth(0)).to_have_text("thruster 1")
        expect(first.nth(1)).to_have_text("0")  # its command, idle after the sweep
        for plot in ("#cal-plot", "#cal-rpm-plot", "#cal-power-plot"):
            expect(page.locator(f"{plot} .main-svg").first).to_be_visible()

        newtons = f"{_js(strongest['thrust_per_thruster_n'], 4)} N"
        expect(figures).to_contain_text(newtons)
        page.check("#cal-units input[value=kgf]")
        kgf = strongest["thrust_per_thruster_n"] / 9.80665
        expect(figures).to_contain_text(f"{_js(kgf, 4)} kgf")
        expect(page.locator("#cal-table thead")).to_contain_text("Thrust per thruster (kgf)")


def _js(value: float, digits: int) -> str:
    """``value`` as the page's ``fmt`` prints it: ``digits`` significant figures, no
    trailing zeros (for values below 10**digits, where neither uses an exponent)."""
    return f"{value:.{digits}g}"


def test_a_job_asked_to_stop_shows_stopping_at_once(chromium, client, service) -> None:
    from playwright.sync_api import expect

    wait_rig_free(client)
    # A slow tow (2 N) that runs until it is aborted: a faster one reached the end of the
    # rail before a loaded box had opened the page.
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 2.0, "max_time_s": 120})
    wait_job(client, job_id, states=("running",))
    with signed_in_page(chromium, service, client) as page:
        expect(page.locator("#job-state")).to_have_text("running")
        expect(page.locator("#job-user")).to_contain_text("started by default at ")
        held: list = []  # the abort request, answered only once "stopping" was seen
        page.route("**/api/jobs/*/abort", lambda route: held.append(route))
        page.click("#abort-btn")
        expect(page.locator("#job-state")).to_have_text("stopping")  # shown before the request
        deadline = time.monotonic() + 10  # the page shows "stopping" before it sends
        while not held and time.monotonic() < deadline:
            page.wait_for_timeout(50)  # Playwright dispatches the route handler meanwhile
        assert len(held) == 1
        held[0].continue_()
        expect(page.locator("#job-state")).to_have_text("aborted")
    job_end = wait_job(client, job_id)
    assert job_end["state"] == "aborted", how_it_ended(job_end)
