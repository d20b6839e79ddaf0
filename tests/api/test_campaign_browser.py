"""A campaign in real headless Chromium: started from the Queue page's Campaign card, its
trail (each test, why, U before → after) shown as it runs and its ending shown; a stop
marker added from the Queue page; a campaign stopped from the card."""

from __future__ import annotations

import re
import time
from datetime import datetime

import pytest

from tests.api.conftest import AUTH, signed_in_page, wait_job, wait_rig_free

#: Slow lane like the other page tests; the rig in simulated time (paced), so a campaign's
#: tows take seconds.
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_a_campaign_started_from_the_page_shows_its_trail_as_it_runs(chromium, client, service):
    from playwright.sync_api import expect

    wait_rig_free(client)
    with signed_in_page(chromium, service, client) as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.click("nav a[data-page=queue]")
        expect(page.locator("#campaign-view")).to_contain_text("No campaign yet")
        form = page.locator("#campaign-form")
        form.locator("[name=axis-yaw]").uncheck()
        form.locator("[name=axis-swing]").uncheck()
        form.locator("[name=max_runs]").fill("2")
        form.locator("button[type=submit]").click()
        expect(page.locator("#campaign-state")).to_have_text("running")
        # while it runs: the test it queued, with the operator's acts and why (the first or,
        # when a loaded box draws the page after the first tow, the second; between them
        # the card says it is estimating)
        expect(page.locator("#campaign-pending")).to_contain_text("hang", timeout=60_000)
        rows = page.locator("#campaign-trail tbody tr")
        # the first booked run appears while the campaign still runs (live, no reload)
        expect(rows).to_have_count(1, timeout=60_000)
        expect(page.locator("#campaign-state")).to_have_text("running")
        expect(rows.nth(0)).to_contain_text("rig tow --force")
        expect(rows.nth(0)).to_contain_text("no fit yet")  # before the first run
        # U after it, each coefficient named as the result and the Estimation page name it
        expect(rows.nth(0)).to_contain_text(re.compile(r"quadratic_damping \S+ %"))
        expect(rows).to_have_count(2, timeout=60_000)
        expect(page.locator("#campaign-state")).to_have_text("completed", timeout=60_000)
        expect(page.locator("#campaign-summary")).to_contain_text("2 of 2 runs")
        job = client.get("/api/campaigns", headers=AUTH).json()[0]
        assert [e["run_id"] for e in job["outcome"]["trail"]] == job["run_ids"]

        # a stop marker from the page: shown in the queue, without an Edit button
        client.post("/api/queue/pause", headers=AUTH)
        page.click("#queue-marker")
        marker = page.locator("#queue-list > li")
        expect(marker).to_have_count(1)
        expect(marker).to_contain_text("stop marker")
        expect(marker.locator("button[data-act=edit]")).to_have_count(0)
        marker.locator("button[data-act=remove]").click()
        expect(marker).to_have_count(0)
        client.post("/api/queue/resume", headers=AUTH)
        assert errors == []
    wait_job(client, job["id"])


def test_a_campaign_stopped_from_the_page_says_stopping_at_once_then_how_it_ended(
    chromium, client, service
):
    """Stop the campaign: the card says "stopping" and why it waits (the run on the rig
    finishes first) before the service answers, then the campaign's ending with its reason;
    the tow it had started completes and is kept."""
    from playwright.sync_api import expect

    wait_rig_free(client)
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=queue]")
        form = page.locator("#campaign-form")
        form.locator("[name=axis-yaw]").uncheck()
        form.locator("[name=axis-swing]").uncheck()
        form.locator("[name=max_runs]").fill("4")
        form.locator("button[type=submit]").click()
        expect(page.locator("#campaign-pending")).to_contain_text("hang", timeout=60_000)
        held: list = []  # the stop request, answered only once "stopping" was seen
        page.route("**/api/campaigns/*/stop", lambda route: held.append(route))
        page.click("#campaign-stop")
        expect(page.locator("#campaign-state")).to_have_text("stopping")
        expect(page.locator("#campaign-stopping")).to_contain_text("the run on the rig finishes")
        expect(page.locator("#campaign-stop")).to_have_count(0)  # asked once, not twice
        deadline = time.monotonic() + 10  # the page shows "stopping" before it sends
        while not held and time.monotonic() < deadline:
            page.wait_for_timeout(50)  # Playwright dispatches the route handler meanwhile
        assert len(held) == 1
        with page.expect_response("**/api/campaigns/*/stop") as answered:
            held[0].continue_()
        assert answered.value.status == 200
        stopped_at = time.time()  # the service had the stop by now
        expect(page.locator("#campaign-state")).to_have_text("aborted", timeout=90_000)
        expect(page.locator("#campaign-summary")).to_contain_text("stopped by the operator")
    job = client.get("/api/campaigns", headers=AUTH).json()[0]
    assert job["state"] == "aborted" and job["outcome"]["outcome"] == "stopped by the operator"
    # no further test after the stop: the run on the rig then (the first, or on a loaded
    # box already the second) finished, and no test was queued once the service had it
    for entry in job["outcome"]["trail"]:
        queued = client.get(f"/api/jobs/{entry['job_id']}", headers=AUTH).json()["created_at"]
        assert datetime.fromisoformat(queued).timestamp() < stopped_at, entry
    assert job["outcome"]["runs_used"] < 4


def test_a_pendulum_campaign_shows_each_release_it_chose_and_why(
    chromium, client, service, tmp_path
):
    """At 1366 × 768: a campaign on the swing axis alone, its opening release and the release
    the planner chose on the first fit, each with its command, why and U before → after."""
    from playwright.sync_api import expect

    wait_rig_free(client)
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1366, "height": 768})
        page.click("nav a[data-page=queue]")
        form = page.locator("#campaign-form")
        for axis in ("surge", "yaw"):
            form.locator(f"[name=axis-{axis}]").uncheck()
        form.locator("[name=target_percent]").fill("0.02")
        form.locator("[name=max_runs]").fill("2")
        form.locator("button[type=submit]").click()
        expect(page.locator("#campaign-pending")).to_contain_text("pull it out", timeout=60_000)
        rows = page.locator("#campaign-trail tbody tr")
        expect(rows).to_have_count(2, timeout=120_000)
        expect(rows.nth(0)).to_contain_text("rig pendulum --angle 0.25")
        expect(rows.nth(0)).to_contain_text("opening")
        expect(rows.nth(1)).to_contain_text("per tank minute")
        # the coefficient the why names is the one its U columns name (no second vocabulary)
        worst = re.search(r"worst target ratio is \S+ \((\w+);", rows.nth(1).inner_text())
        assert worst, rows.nth(1).inner_text()
        expect(rows.nth(1).locator("td").nth(4)).to_contain_text(f"{worst[1]} ")
        expect(page.locator("#campaign-state")).to_have_text("completed", timeout=120_000)
        page.locator("#campaign-view").scroll_into_view_if_needed()
        page.screenshot(path=str(tmp_path / "campaign-pendulum.png"))
    job = client.get("/api/campaigns", headers=AUTH).json()[0]
    assert job["outcome"]["axes"] == ["swing"] and len(job["outcome"]["trail"]) == 2
