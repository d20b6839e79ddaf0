"""Stored results found again in real headless Chromium at 1366×768: after a reload the
estimate is in the Estimation page's list of stored results, opens as a fresh one is drawn
(and survives another reload: the hash names it), downloads as a zip holding report.md and
the figures, compares with a second result (the difference in σ), and is linked from the
page of a run it was made from."""

from __future__ import annotations

import zipfile

import pytest

from tests.api.conftest import (
    AUTH,
    completed_tows,
    estimate_in_page,
    how_it_ended,
    signed_in_page,
    wait_job,
)

# a browser page: the slow lane; its two tows on the simulated rig (paced service)
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def test_a_result_is_found_again_downloaded_and_compared(chromium, client, service, tmp_path):
    from playwright.sync_api import expect

    runs = completed_tows(client, (24.5, 83.3))
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1366, "height": 768})
        estimate_in_page(page, runs, timeout_ms=120_000)
        first = client.get("/api/results?kind=estimation&limit=1", headers=AUTH).json()[0]
        # the fresh result is listed at once, before any reload
        fresh = page.locator(f"#results-table tbody tr[data-result='{first['id']}']")
        expect(fresh).to_be_visible()
        # a second result of the same runs, made by a lab tool (no effect search)
        body = {"run_ids": runs, "search_effects": False}
        made = client.post("/api/jobs/estimation", json=body, headers=AUTH)
        second = wait_job(client, made.json()["id"], timeout_s=120)
        assert second["state"] == "completed", how_it_ended(second)
        one, two = first["id"], second["result_id"]

        page.reload()  # the fresh result is gone from the card; the list has it
        expect(page.locator("#est-result")).to_be_hidden()
        row = page.locator(f"#results-table tbody tr[data-result='{one}']")
        expect(row).to_contain_text("estimation")
        expect(row).to_contain_text(runs[0][:8])
        row.locator("a.result-link").click()
        expect(page).to_have_url(f"{page.url.split('#')[0]}#results/{one}")
        expect(page.locator("#est-result")).to_be_visible()
        expect(page.locator("#est-coefs")).to_contain_text("inertia")
        expect(page.locator("#est-plots figure")).to_have_count(len(first["report_plots"]))
        page.screenshot(path=str(tmp_path / "results-open.png"))

        page.reload()  # the hash names the open result: it is drawn again
        expect(page.locator("#est-status")).to_contain_text(f"Stored result #{one}")
        expect(page.locator("#est-plots figure")).to_have_count(len(first["report_plots"]))

        with page.expect_download() as download:
            page.locator(f"#results-table tr[data-result='{one}'] .result-zip").click()
        assert download.value.suggested_filename == f"result-{one}-report.zip"
        saved = tmp_path / download.value.suggested_filename
        download.value.save_as(saved)
        names = {n.split("/")[-1] for n in zipfile.ZipFile(saved).namelist()}
        assert {"report.md", "fit.png", "force_residual.png", "result.json"} <= names

        for result_id in (one, two):
            page.check(f"#results-table tr[data-result='{result_id}'] input[type=checkbox]")
        page.click("#results-compare")
        table = page.locator("#results-compare-table")
        expect(table).to_contain_text(
            f"#{one} − #{two} (σ)"
        )  # ticked newest first: #two is the reference
        expected = client.get(f"/api/results/compare?ids={two},{one}", headers=AUTH).json()
        for row_doc in expected["coefficients"]:
            cell = table.locator(f"tr[data-coefficient='{row_doc['coefficient']}'] td.difference")
            wanted = row_doc["difference_sigma"][1]
            if wanted is None:
                expect(cell).to_have_text("—")
            else:
                assert float(cell.inner_text()) == pytest.approx(wanted, rel=1e-2, abs=1e-3)
        table.scroll_into_view_if_needed()
        page.screenshot(path=str(tmp_path / "results-compare.png"))

        page.click("nav a[data-page=runs]")
        page.locator(f"#runs-table tbody tr[data-run='{runs[0]}']").click()
        link = page.locator(f"#run-results a[href='#results/{one}']")
        expect(link).to_be_visible()
        page.screenshot(path=str(tmp_path / "run-results.png"))
        link.click()
        expect(page.locator("#page-estimation")).to_be_visible()
        expect(page.locator("#est-status")).to_contain_text(f"Stored result #{one}")

        # ls-steady through the two runs: its drag law has no residual, so K_L and K_Q have
        # no σ and no U; the page says so where a σ would stand, never "± —" or a round-off σ
        body = {"run_ids": runs, "method": "ls-steady"}
        made = client.post("/api/jobs/estimation", json=body, headers=AUTH)
        steady = wait_job(client, made.json()["id"], timeout_s=120)
        assert steady["state"] == "completed", how_it_ended(steady)
        page.goto(f"{page.url.split('#')[0]}#results/{steady['result_id']}")
        expect(page.locator("#est-status")).to_contain_text(f"#{steady['result_id']}")
        for name in ("linear_damping", "quadratic_damping"):
            row = page.locator("#est-coefs tbody tr", has_text=name).first
            expect(row).to_contain_text("not identified (no σ)")
        inertia = page.locator("#est-coefs tbody tr", has_text="inertia").first
        expect(inertia).to_contain_text("± ")
        # its budget row: no U, so no k and no ν_eff either (not "1.96" and "∞")
        cells = page.locator(".est-budget-summary tr[data-quantity='linear_damping'] td")
        expect(cells.nth(1)).to_contain_text("not identified: no U")
        expect(cells.nth(2)).to_have_text("—")
        expect(cells.nth(3)).to_have_text("—")
        stored = client.get(f"/api/results/{steady['result_id']}", headers=AUTH).json()
        expect(page.locator("#est-plots figure")).to_have_count(len(stored["report_plots"]))
        page.screenshot(path=str(tmp_path / "results-no-sigma.png"), full_page=True)
