"""The Rig page's run metadata block in real headless Chromium: filled once, sent with a
tow started from the page, stored on the run; operator remembered; a 422 shown by the field."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, TOKEN

# a browser page: the slow lane; the tow it starts on the simulated rig (paced service)
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_a_tow_started_from_the_page_carries_the_run_metadata(chromium, live_url):
    from playwright.sync_api import expect

    base = str(live_url.base_url).rstrip("/")
    with chromium.page() as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.goto(f"{base}/#token={TOKEN}")
        expect(page.locator("#conn-text")).to_contain_text("simulated")
        meta = page.locator("#form-metadata")
        expect(meta).to_be_hidden()  # collapsed until opened
        page.click("#run-metadata summary")
        meta.locator("[name=operator]").fill("Grace")
        meta.locator("[name=tags]").fill("fins-v2, page")
        meta.locator("[name=salinity_g_kg]").fill("35.165")  # a sea-water tank

        # an out-of-range temperature: the API's 422 shown by that field, nothing started
        meta.locator("[name=water_temperature_c]").fill("80")
        page.fill("#form-tow [name=force_n]", "24.5")
        page.fill("#form-tow [name=max_time_s]", "1.5")
        page.fill("#form-tow [name=baseline_s]", "0.3")
        page.click("#start-tow")
        expect(meta.locator(".errors")).to_contain_text("metadata.water_temperature_c: 80")
        expect(meta.locator("[name=water_temperature_c]")).to_have_class("invalid")
        assert live_url.get("/api/rig").json()["current_job"] is None

        meta.locator("[name=water_temperature_c]").fill("")
        page.click("#start-tow")
        expect(meta.locator(".errors")).to_be_empty()
        expect(page.locator("#job-state")).to_have_text("completed", timeout=30_000)
        run_id = page.text_content("#job-runs").strip()
        run = live_url.get(f"/api/runs/{run_id}", headers=AUTH).json()
        job = live_url.get("/api/jobs?limit=1", headers=AUTH).json()[0]
        origin = {"started_by": "default", "job_id": job["id"]}  # who and which job
        stored = {"operator": "Grace", "salinity_g_kg": 35.165, "tags": ["fins-v2", "page"]}
        assert run["metadata"] == stored | origin

        page.reload()  # the operator is remembered for the next test, the tags are not
        page.click("#run-metadata summary")
        expect(meta.locator("[name=operator]")).to_have_value("Grace")
        expect(meta.locator("[name=salinity_g_kg]")).to_have_value("35.165")  # the same tank
        expect(meta.locator("[name=tags]")).to_have_value("")
        assert not errors, errors
