"""In real headless Chromium: the Emergency stop button works on a page that has no token
(the token dialog open beside it), and an operator then acknowledges the stop from the
Rig page before the rig takes a start again."""

from __future__ import annotations

import pytest

from api.http.app import create_app
from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    TOKEN,
    LiveServer,
    how_it_ended,
    start_job,
    wait_job,
)

#: Slow lane: an extra browser page (tests/api/test_browser.py stays in the fast lane).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_the_emergency_stop_button_works_without_a_token(chromium, client, service) -> None:
    from playwright.sync_api import expect

    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, chromium.page() as page:
        page.goto(live.url)  # no #token=…: the page cannot read the rig
        expect(page.locator("#token-dialog")).to_be_visible()
        job_id = start_job(client, "/api/jobs/tow", {"force_n": 10.0, "max_time_s": 30})
        wait_job(client, job_id, states=("running",))

        page.click("#estop-btn")  # not behind the dialog: a covered button times out here
        expect(page.locator("#job-panel")).to_contain_text("Emergency stop: aborted 1 job(s)")
        job_end = wait_job(client, job_id, timeout_s=10)
        assert job_end["state"] == "aborted", how_it_ended(job_end)
        refused = client.post("/api/jobs/tow", json=SHORT_TOW, headers=AUTH)
        assert refused.status_code == 409 and "not acknowledged" in refused.json()["detail"]

        page.fill("#token-input", TOKEN)  # an operator signs in and acknowledges
        page.click("#token-form button[type=submit]")
        expect(page.locator("#estop-latched")).to_contain_text("refuses motion")
        page.click("#estop-ack-btn")
        expect(page.locator("#estop-latched")).to_have_count(0)
        events = client.get("/api/rig/events", headers=AUTH).json()
        assert [(e["kind"], e["user"]) for e in events[:2]] == [
            ("estop_ack", "default"),
            ("estop", None),
        ]
        wait_job(client, start_job(client, "/api/jobs/tow", SHORT_TOW))


def test_a_stop_pressed_elsewhere_shows_on_an_open_page_without_its_poll(
    chromium, client, service
) -> None:
    """The page's timers are stopped once it shows the rig (Playwright's clock): its 2 s
    status poll never fires again, so the stop pressed by a lab tool, and its
    acknowledgement, can reach the page only through the stream's ``guard`` event."""
    from playwright.sync_api import expect

    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, chromium.page() as page:
        page.clock.install()
        page.goto(f"{live.url}#token={TOKEN}")
        expect(page.locator("#hold-btn")).to_be_visible()  # the guard, drawn from a status
        expect(page.locator("#live-count")).not_to_have_text("0")  # the stream delivers
        page.clock.pause_at(page.evaluate("Date.now()") + 1000)  # no page timer fires now

        assert client.post("/api/rig/emergency-stop").status_code == 200
        expect(page.locator("#estop-latched")).to_contain_text("refuses motion")
        assert client.post("/api/estop/ack", headers=AUTH).status_code == 200
        expect(page.locator("#estop-latched")).to_have_count(0)
