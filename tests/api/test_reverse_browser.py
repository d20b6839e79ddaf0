"""The reverse run the estimator asks for, started from the Estimation page in real
headless Chromium: on a rig with dry friction and a current, forward tows leave the two
ambiguous; the result shows a button naming the reverse tow, and clicking it starts that
tow (negative force, from the far end) on the rig."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.api.conftest import (
    AUTH,
    completed_tows,
    estimate_in_page,
    how_it_ended,
    signed_in_page,
    wait_job,
)

SCENARIO = Path(__file__).resolve().parents[2] / "fixtures/scenarios/friction-and-current.toml"
#: Slow lane: three tows (in process, simulated time, the scenario's plant), an estimation
#: and the reverse tow it starts.
pytestmark = [pytest.mark.slow, pytest.mark.rig_service(scenario=SCENARIO)]


def test_the_reverse_button_starts_the_reverse_tow(chromium, client, service):
    from playwright.sync_api import expect

    runs = completed_tows(client, (24.5, 44.1, 83.3), {"max_time_s": 5.0, "baseline_s": 0.5})
    with signed_in_page(chromium, service, client) as page:
        estimate_in_page(page, runs, timeout_ms=180_000)
        # advice (what to run next) is set apart from a warning (the result may be wrong)
        expect(page.locator("#est-ambiguous p.muted")).to_contain_text("rig tow --force -83.3")
        expect(page.locator("#est-ambiguous p.warning")).to_contain_text("poorly separated")
        button = page.locator("#est-reverse-btn")
        expect(button).to_be_visible()
        expect(page.locator("#est-reverse code")).to_have_text("rig tow --force -83.3")
        button.click()
        expect(page.locator("#est-reverse-status")).to_contain_text("started: tow -83.3 N")
        # the event stream may report the estimation's completion after the poll did: that
        # late report must not redraw the result and clear what the user started from it
        estimation = next(
            j for j in client.get("/api/jobs", headers=AUTH).json() if j["kind"] == "estimation"
        )
        page.evaluate(
            "id => Promise.all([import('/static/stream.js'), import('/static/api.js')])"
            ".then(async ([s, a]) => s.jobEvent(await a.api('GET', `/api/jobs/${id}`)))",
            estimation["id"],
        )
        expect(page.locator("#est-reverse-status")).to_contain_text("started: tow -83.3 N")

    jobs = client.get("/api/jobs", headers=AUTH).json()
    reverse = next(j for j in jobs if j["label"].startswith("tow -83.3"))
    done = wait_job(client, reverse["id"], timeout_s=60)
    assert done["state"] == "completed", how_it_ended(done)
    run = client.get(f"/api/runs/{done['run_ids'][0]}", headers=AUTH).json()
    assert run["parameters"]["force_n"] == pytest.approx(-83.3)
    assert run["parameters"]["hung_mass_kg"] == pytest.approx(8.5)
