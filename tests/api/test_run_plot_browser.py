"""In real headless Chromium at 1366 × 768 (issue 32): on the run page one channel is plotted
against another with units on both axes, and a second run is overlaid, each run named in
the legend; back on time, the same runs are drawn as lines against time."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.api.conftest import AUTH, signed_in_page

#: Slow lane: a browser. The CSV imports only stock the runs (``imports_in_a_thread``).
pytestmark = [pytest.mark.slow, pytest.mark.usefixtures("imports_in_a_thread")]

CSV = {"Content-Type": "text/csv"}
SHOTS = Path("/tmp/plots-shots")
PLOT = "document.getElementById('run-plot')"


def test_a_channel_against_another_with_two_runs_overlaid(chromium, client, service, tmp_path):
    from playwright.sync_api import expect

    from tests.integration.test_import_kinds import _tow_csv

    ids = []
    for force, seed in ((30.0, 1), (20.0, 2)):
        _tow_csv(tmp_path / "tow.csv", force, seed)
        query = "kind=tow&drive_column=pull%20(kgf)&drive_unit=kgf&release_time_s=1"
        body = (tmp_path / "tow.csv").read_bytes()
        r = client.post(f"/api/runs/import?{query}", content=body, headers=AUTH | CSV)
        assert r.status_code == 201, r.text
        ids.append(r.json()["run_id"])
    forces = [
        client.get(f"/api/runs/{i}/samples?limit=100000", headers=AUTH).json()["channels"][
            "drive_force"
        ]
        for i in ids
    ]
    with signed_in_page(chromium, service, client) as page:
        page.set_viewport_size({"width": 1366, "height": 768})
        page.click("nav a[data-page=runs]")
        page.click(f"#runs-table tbody tr[data-run='{ids[0]}']")
        expect(page.locator("#run-channels input:checked")).to_have_count(1)
        page.check("#run-channels input[value=drive_force]")
        page.select_option("#run-x", "drive_force")  # tow position against drive force
        expect(page.locator("#run-channels input[value=drive_force]")).to_be_disabled()
        page.select_option("#run-overlay-pick", ids[1])
        expect(page.locator("#run-overlays .tag")).to_have_count(1)
        page.wait_for_function(f"() => {PLOT}.data && {PLOT}.data.length === 2")
        traces = page.evaluate(f"{PLOT}.data.map(t => [t.name, t.mode, t.x])")
        layout = page.evaluate(f"{PLOT}.layout")
        assert layout["xaxis"]["title"]["text"] == "drive force [N]"
        assert layout["yaxis"]["title"]["text"] == "tow position [m]"
        assert [t[1] for t in traces] == ["markers", "markers"]
        for (name, _, x), run_id, force in zip(traces, ids, forces, strict=True):
            assert name.startswith("tow position [m] · ") and f"{run_id[:8]} tow" in name, name
            assert x == force  # each run's own drive force on x
        SHOTS.mkdir(exist_ok=True)
        page.locator("#run-plot").screenshot(path=str(SHOTS / "run-plot-y-against-x.png"))
        page.locator("#run-x").scroll_into_view_if_needed()
        page.screenshot(path=str(SHOTS / "run-page-1366.png"))

        page.select_option("#run-x", "time")
        page.wait_for_function(f"() => {PLOT}.data.every(t => t.mode === 'lines')")
        expect(page.locator("#run-channels input[value=drive_force]")).to_be_enabled()
        assert len(page.evaluate(f"{PLOT}.data")) == 4  # both channels of both runs
        assert page.evaluate(f"{PLOT}.layout.xaxis.title.text").startswith("time from ")
        page.locator("#run-plot").screenshot(path=str(SHOTS / "run-plot-overlay-time.png"))
