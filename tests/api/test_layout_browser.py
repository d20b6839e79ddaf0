"""At 1280×800, as a lab PC shows it, in real headless Chromium: the Rig page has the job
and start cards in view without scrolling, and the Estimation and Cross-check run tables
fit their cards (no column hidden past the card's edge), with long tags in the rows."""

from __future__ import annotations

import pytest

from tests.api.conftest import AUTH, signed_in_page

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane). The CSV
#: imports only stock the tables: imported in a thread (``imports_in_a_thread``).
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("imports_in_a_thread")]

CSV = {"Content-Type": "text/csv"}
TOW = "t,position\n" + "".join(f"{k / 10:.1f},{0.002 * k * k:.4f}\n" for k in range(60))
FITS = """sel => {
  const table = document.querySelector(sel);
  const card = table.closest('.card');
  return [table.scrollWidth, card.clientWidth - 2 * parseFloat(getComputedStyle(card).paddingLeft)];
}"""


@pytest.fixture(scope="module")
def imported(client, imports_in_a_thread) -> list[str]:
    ids = []
    for force in (10, 20, 30):
        query = f"kind=tow&force_n={force}&tag=fins-long-name-v2&tag=repeat-{force}"
        r = client.post(f"/api/runs/import?{query}", content=TOW.encode(), headers=AUTH | CSV)
        assert r.status_code == 201, r.text
        ids.append(r.json()["run_id"])
    return ids


def test_at_1280_by_800_the_work_fits_the_window(chromium, client, service, imported):
    from playwright.sync_api import expect

    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1280, "height": 800})
        page.reload()
        expect(page.locator("#job-panel")).to_be_visible()
        for heading in ("Current job", "Start a test"):
            box = page.get_by_role("heading", name=heading).bounding_box()
            assert box is not None and box["y"] + box["height"] <= 800, (heading, box)

        page.click("nav a[data-page=estimation]")
        expect(page.locator("#est-runs tbody tr")).to_have_count(len(imported))
        table, room = page.evaluate(FITS, "#est-runs")
        assert table <= room + 1, (table, room)

        page.click("nav a[data-page=crosscheck]")
        expect(page.locator("#cc-runs tbody tr").first).to_be_visible()
        table, room = page.evaluate(FITS, "#cc-runs")
        assert table <= room + 1, (table, room)


def test_run_detail_plots_chosen_channels_with_units_and_overlays_a_run(
    chromium, client, service, tmp_path
):
    from playwright.sync_api import expect

    from tests.integration.test_import_kinds import _tow_csv

    ids = []
    for force, seed in ((30.0, 1), (20.0, 2)):
        _tow_csv(tmp_path / "tow.csv", force, seed)
        query = "kind=tow&drive_column=pull%20(kgf)&drive_unit=kgf&release_time_s=1"
        r = client.post(
            f"/api/runs/import?{query}",
            content=(tmp_path / "tow.csv").read_bytes(),
            headers=AUTH | CSV,
        )
        assert r.status_code == 201, r.text
        ids.append(r.json()["run_id"])
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=runs]")
        page.click(f"#runs-table tbody tr[data-run='{ids[0]}']")
        expect(page.locator("#run-channels input:checked")).to_have_count(1)
        page.check("#run-channels input[value=drive_force]")
        page.select_option("#run-overlay-pick", ids[1])
        expect(page.locator("#run-overlays .tag")).to_have_count(1)
        page.wait_for_function(
            "() => document.getElementById('run-plot').data && "
            "document.getElementById('run-plot').data.length === 4"
        )
        layout = page.evaluate("document.getElementById('run-plot').layout")
        titles = sorted(layout[k]["title"]["text"] for k in ("yaxis", "yaxis2"))
        assert titles == ["drive force [N]", "tow position [m]"]  # a row per unit
        assert layout["xaxis"]["title"]["text"].startswith("time from ")
        names = page.evaluate("document.getElementById('run-plot').data.map(t => t.name)")
        assert sum(ids[1][:8] in n for n in names) == 2 and sum(ids[0][:8] in n for n in names) == 2
        page.click(f"#run-overlays button[data-drop='{ids[1]}']")
        page.wait_for_function("() => document.getElementById('run-plot').data.length === 2")
