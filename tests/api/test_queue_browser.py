"""The queue in real headless Chromium: the Rig page says the queue is paused, why, and what
runs next, and resumes it; the Queue page shows queued jobs live, reorders, edits (a 422
shown, then saved), removes, stops after the current job, runs a job now; the history shows
a finished job and re-queues it; a sequence file is started from the page; after a restart
with a job queued the Rig page says why it waits."""

from __future__ import annotations

import pytest

from tests.api.conftest import (
    AUTH,
    SHORT_TOW,
    TOKEN,
    completed_tows,
    how_it_ended,
    signed_in_page,
    simulated_service,
    wait_job,
)
from tests.api.conftest import wait_rig_free as rig_free

#: Slow lane: a browser per test, like the other page tests. The tests are about the pages:
#: their tows run on the simulated rig in process on simulated time (a paced service), the
#: real stack behind a page is tests/api/test_browser.py's.
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def _post(client, path: str, body: dict) -> dict:
    r = client.post(path, json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    return r.json()


def _queue_ids(client) -> list[str]:
    return [j["id"] for j in client.get("/api/queue", headers=AUTH).json()["jobs"]]


def test_queued_jobs_shown_reordered_edited_removed_and_the_paused_queue_resumed(
    chromium, client, service
):
    from playwright.sync_api import expect

    rig_free(client)
    client.post("/api/queue/pause", headers=AUTH)  # queued jobs wait: nothing moves
    first = _post(client, "/api/jobs/tow", SHORT_TOW)
    second = _post(client, "/api/jobs/tow", SHORT_TOW | {"force_n": 44.1})
    with signed_in_page(chromium, service, client) as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.set_viewport_size({"width": 1280, "height": 800})
        # The Rig page: paused, why, what is next, and a Resume button.
        expect(page.locator("#queue-summary-paused")).to_contain_text("stopped by the operator")
        expect(page.locator("#queue-summary-text")).to_contain_text("2 waiting")
        expect(page.locator("#queue-summary-text")).to_contain_text(first["label"])
        start = page.get_by_role("heading", name="Start a test").bounding_box()
        assert start is not None and start["y"] + start["height"] <= 800, start  # still in view

        page.click("nav a[data-page=queue]")
        items = page.locator("#queue-list > li")
        expect(items).to_have_count(2)
        expect(page.locator("#queue-reason")).to_contain_text("stopped by the operator")
        expect(items.nth(0)).to_contain_text(first["label"])
        expect(items.nth(0).locator(".params")).to_contain_text("max time 1.5 s")
        third = _post(client, "/api/jobs/spin", {"torque_nm": 0.454, "max_time_s": 1.0})
        expect(items).to_have_count(3)  # live: posted elsewhere, shown without a reload

        # Reorder: the second tow up to first place.
        page.locator(f"#queue-list li[data-job='{second['id']}'] button[data-act=up]").click()
        expect(items.nth(0)).to_have_attribute("data-job", second["id"])
        assert _queue_ids(client) == [second["id"], first["id"], third["id"]]

        # Edit the first tow: a force over the rig's limit is refused by the field, then saved.
        page.locator(f"#queue-list li[data-job='{first['id']}'] button[data-act=edit]").click()
        form = page.locator(f"#queue-list li[data-job='{first['id']}'] form.queue-edit")
        expect(form.locator("[name=force_n]")).to_have_value("24.5")
        form.locator("[name=force_n]").fill("500")
        form.locator("button[type=submit]").click()
        expect(form.locator(".errors")).to_contain_text("force_n")
        expect(form.locator("[name=force_n]")).to_have_class("invalid")
        form.locator("[name=force_n]").fill("30")
        form.locator("button[type=submit]").click()
        expect(form).to_have_count(0)
        edited = client.get(f"/api/jobs/{first['id']}", headers=AUTH).json()
        assert edited["request"]["force_n"] == 30 and edited["position"] == 2, edited
        expect(items.nth(1)).to_contain_text(edited["label"])

        # Remove the spin and the 44.1 N tow.
        for job in (third, second):
            page.locator(f"#queue-list li[data-job='{job['id']}'] button[data-act=remove]").click()
        expect(items).to_have_count(1)
        assert _queue_ids(client) == [first["id"]]

        # Back on the Rig page, resume: the edited tow runs and the pause note goes.
        page.click("nav a[data-page=rig]")
        expect(page.locator("#queue-summary-text")).to_contain_text("1 waiting")
        page.click("#queue-summary-resume")
        expect(page.locator("#queue-summary-paused")).to_have_count(0)
        job_end = wait_job(client, first["id"])
        assert job_end["state"] == "completed", how_it_ended(job_end)
        expect(page.locator("#queue-summary-text")).to_have_text("empty")
        assert not errors, errors


def test_history_requeues_a_finished_job_and_a_sequence_starts_from_the_page(
    chromium, client, service
):
    from playwright.sync_api import expect

    completed_tows(client, [24.5])
    done = client.get("/api/jobs?state=completed&limit=1", headers=AUTH).json()[0]
    with signed_in_page(chromium, service, client) as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.click("nav a[data-page=queue]")
        # Stop after the current job (nothing runs): what is queued next waits.
        page.click("#queue-stop")
        expect(page.locator("#queue-reason")).to_contain_text("no further job starts")
        try:
            row = page.locator(f"#history-table tr[data-job='{done['id']}']")
            expect(row).to_contain_text("completed")
            expect(row).to_contain_text(done["label"])
            row.locator("button[data-requeue]").click()
            items = page.locator("#queue-list > li")
            expect(items).to_have_count(1)
            expect(items.nth(0)).to_contain_text(done["label"])
            queue = client.get("/api/queue", headers=AUTH).json()
            assert queue["jobs"][0]["request"] == done["request"], queue

            seq = page.locator("#sequence-list li[data-file='seed000-campaign']")
            expect(seq).to_contain_text("8 run(s)")
            seq.locator("button[data-start]").click()
            expect(items).to_have_count(2)
            expect(items.nth(1)).to_contain_text("sequence seed 000 campaign")
            expect(items.nth(1).locator(".params")).to_contain_text("step 8")
            assert [j["kind"] for j in client.get("/api/queue", headers=AUTH).json()["jobs"]] == [
                "tow",
                "sequence",
            ]
            assert client.get("/api/rig", headers=AUTH).json()["current_job"] is None

            # Remove the sequence, run the re-queued tow now: the queue resumes, it runs.
            items.nth(1).locator("button[data-act=remove]").click()
            expect(items).to_have_count(1)
            requeued = items.nth(0).get_attribute("data-job")
            items.nth(0).locator("button[data-act=run-now]").click()
            expect(page.locator("#queue-reason")).to_have_count(0)
            expect(items).to_have_count(0)
            job_end = wait_job(client, requeued)
            assert job_end["state"] == "completed", how_it_ended(job_end)
            expect(page.locator(f"#history-table tr[data-job='{requeued}']")).to_contain_text(
                "completed"
            )
        finally:
            for job_id in _queue_ids(client):
                client.delete(f"/api/queue/{job_id}", headers=AUTH)
            client.post("/api/queue/resume", headers=AUTH)
        assert not errors, errors


def test_after_a_restart_with_a_job_queued_the_rig_page_says_why_it_waits_and_resumes(
    chromium, tmp_path
):
    """The issue's case: the service restarts with a job queued; the Rig page said "No job
    yet" and a tow started there waited at "queued (position 2)" with no reason and no
    Resume button."""
    from fastapi.testclient import TestClient
    from playwright.sync_api import expect

    from api.core.service import RigService
    from api.http.app import create_app
    from daq.session import RigSource

    def app_on(service: RigService):
        return create_app(service, token=TOKEN, report_root=tmp_path / "reports")

    url = f"sqlite:///{tmp_path / 'rig.db'}"
    with TestClient(app_on(simulated_service(RigSource.load(), url))) as before:
        before.post("/api/queue/pause", headers=AUTH)
        waiting = _post(before, "/api/jobs/tow", SHORT_TOW)
    service = simulated_service(RigSource.load(), url)
    with TestClient(app_on(service)) as client, signed_in_page(chromium, service, client) as page:
        expect(page.locator("#queue-summary-paused")).to_contain_text("the service started")
        expect(page.locator("#queue-summary-text")).to_contain_text(waiting["label"])
        page.fill("#form-tow [name=force_n]", "44.1")
        page.fill("#form-tow [name=max_time_s]", "1.5")
        page.fill("#form-tow [name=baseline_s]", "0.3")
        page.click("#start-tow")
        expect(page.locator("#job-message")).to_have_text("queued (position 2)")
        expect(page.locator("#queue-summary-text")).to_contain_text("2 waiting")
        page.click("#queue-summary-resume")
        expect(page.locator("#queue-summary-paused")).to_have_count(0)
        job_end = wait_job(client, waiting["id"])
        assert job_end["state"] == "completed", how_it_ended(job_end)
        expect(page.locator("#job-state")).to_have_text("completed", timeout=30_000)
        expect(page.locator("#job-panel")).to_contain_text("tow 44.1 N")
        expect(page.locator("#queue-summary-text")).to_have_text("empty")
