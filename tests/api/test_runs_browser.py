"""The Runs page in real headless Chromium: filters (kind pendulum, drive, source, tag,
local days), paging past a page with the total, and annotating a run."""

from __future__ import annotations

import re
from datetime import date

import pytest

from daq.sample import Sample
from daq.store import Store
from tests.api.conftest import TOKEN
from tests.store.helpers import new_run

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)


@pytest.fixture(scope="module")
def stocked(service, live_url) -> tuple[str, str, str]:
    """56 runs: 53 weight tows, 2 tagged pendulums, 1 imported tow; the live server's URL,
    and the first and last local day the tows can have been recorded on (ISO dates: the
    same day unless the stocking ran across midnight)."""
    first_day = date.today().isoformat()
    with Store(service.store_url) as store:
        for i in range(53):
            run = new_run(store, parameters={"force_n": 9.8, "hung_mass_kg": 1.0 + i / 1000})
            store.finish_run(run, "completed")
        last_day = date.today().isoformat()
        for _ in range(2):
            run = new_run(store, kind="pendulum", parameters={"start_angle_rad": 0.2},
                          metadata={"operator": "Ada", "tags": ["decay"]})  # fmt: skip
            store.finish_run(run, "completed")
        samples = [
            Sample(i, i * 0.1, 1.7e9 + i * 0.1, {"tow_position": i * 0.01}) for i in range(5)
        ]
        store.import_run(
            kind="tow", parameters={"force_n": 5.0}, channel_names=["tow_position"],
            rig_name="imported", vehicle="unknown", rig_toml="", samples=samples,
            started_at=1.7e9, stopped_at=1.7e9 + 0.4, source_file="bench_day1.csv",
        )  # fmt: skip
    return str(live_url.base_url).rstrip("/"), first_day, last_day


def test_runs_page_filters_pages_and_annotates(chromium, stocked):
    from playwright.sync_api import expect

    url, first_day, last_day = stocked
    with chromium.page() as page:
        errors: list[str] = []
        page.on("pageerror", lambda err: errors.append(str(err)))
        page.goto(f"{url}/#token={TOKEN}")
        page.wait_for_load_state()
        assert not errors, errors
        page.click("nav a[data-page=runs]")
        count = page.locator("#runs-count")
        expect(count).to_have_text(re.compile(r"^1–50 of (\d+)$"))
        total = int(count.text_content().split(" of ")[1])
        assert total >= 56
        rows = page.locator("#runs-table tbody tr")
        expect(rows).to_have_count(50)
        page.click("#runs-next")
        expect(count).to_have_text(f"51–{total} of {total}")
        expect(rows).to_have_count(total - 50)
        expect(page.locator("#runs-next")).to_be_disabled()

        page.select_option("#runs-filter select[name=kind]", "pendulum")
        page.click("#runs-filter button[type=submit]")
        expect(count).to_have_text("1–2 of 2")
        expect(rows.first).to_contain_text("decay")
        expect(rows.first).to_contain_text("0.2 rad")  # the parameter its kind shows
        page.select_option("#runs-filter select[name=kind]", "")

        page.select_option("#runs-filter select[name=source]", "imported")
        page.click("#runs-filter button[type=submit]")
        expect(count).to_have_text("1–1 of 1")
        expect(rows.first).to_contain_text("bench_day1.csv")
        expect(rows.first.locator("td").nth(3)).to_have_text("5 N")
        page.select_option("#runs-filter select[name=source]", "")

        page.fill("#runs-filter input[name=vehicle]", "no such vehicle")
        page.click("#runs-filter button[type=submit]")
        expect(count).to_have_text("0–0 of 0")
        expect(rows).to_have_text(["no stored run matches these filters"])  # not a blank table
        page.fill("#runs-filter input[name=vehicle]", "")

        # the days the tows were recorded on, as the browser's (this machine's) local days;
        # not date.today(): a run that crossed midnight filtered its tows out (a rehearsal)
        page.fill("#runs-filter input[name=since]", first_day)
        page.fill("#runs-filter input[name=until]", last_day)
        page.select_option("#runs-filter select[name=drive]", "weight")
        page.click("#runs-filter button[type=submit]")
        expect(count).to_have_text(re.compile(r"^1–50 of (5[3-9]|[6-9]\d|\d{3,})$"))  # the tows

        rows.first.click()
        form = page.locator("#run-annotate")
        form.locator("input[name=operator]").fill("Grace")
        form.locator("input[name=tags]").fill("fins-v2, repeat")
        form.locator("input[name=water_temperature_c]").fill("18.5")
        form.locator("button[type=submit]").click()
        expect(page.locator("#run-annotate-status")).to_have_text("saved")
        expect(page.locator("#run-meta")).to_contain_text("18.5 °C")
        form.locator("input[name=water_temperature_c]").fill("80")
        form.locator("button[type=submit]").click()
        expect(page.locator("#run-annotate-status")).to_contain_text("water_temperature_c")

        page.fill("#runs-filter input[name=tag]", "fins-v2")
        page.click("#runs-filter button[type=submit]")
        expect(count).to_have_text("1–1 of 1")
        expect(rows.first).to_contain_text("repeat")
