"""Throwaway (not committed): the Queue page's Campaign card after a campaign, at 1366 px."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, signed_in_page, wait_job, wait_rig_free

pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_shot(chromium, client, service):
    from playwright.sync_api import expect

    wait_rig_free(client)
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1366, "height": 768})
        page.click("nav a[data-page=queue]")
        form = page.locator("#campaign-form")
        form.locator("[name=axis-yaw]").uncheck()
        form.locator("[name=max_runs]").fill("3")
        form.locator("button[type=submit]").click()
        expect(page.locator("#campaign-state")).to_have_text("completed", timeout=120_000)
        page.locator("#campaign-view").scroll_into_view_if_needed()
        page.screenshot(path="/tmp/shots/campaign-queue.png", full_page=True)
    job = client.get("/api/campaigns", headers=AUTH).json()[0]
    wait_job(client, job["id"])
