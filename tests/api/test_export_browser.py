"""The Runs page's *Export as* menu in real headless Chromium: it lists every format of
``daq.export_formats.FORMATS`` (from ``GET /api/export-formats``) with its label, and the
MATLAB entry downloads a ``.mat`` that scipy reads back with the run's units and id."""

from __future__ import annotations

import pytest
from scipy.io import loadmat

from daq.export_formats import FORMATS
from tests.api.conftest import csp_blocked, signed_in_page
from tests.store.test_export_formats import recorded_tow

pytestmark = pytest.mark.slow  # real stack in real time: the slow lane (README, Tests)


def test_export_menu_lists_every_format_and_downloads_mat(chromium, service, client, tmp_path):
    from playwright.sync_api import expect

    run_id = recorded_tow(service.store)
    with signed_in_page(chromium, service, client) as page:
        page.click("nav a[data-page=runs]")
        page.locator(f"#runs-table tbody tr[data-run='{run_id}']").click()
        expect(page.locator("#run-detail-id")).to_have_text(run_id)
        options = page.locator("#export-format option")
        expect(options).to_have_count(len(FORMATS))
        listed = options.evaluate_all("os => os.map((o) => [o.value, o.textContent])")
        assert listed == [[f.name, f.label] for f in FORMATS.values()]

        page.select_option("#export-format", "mat")
        with page.expect_download() as download:
            page.click("#export-run")
        assert download.value.suggested_filename == f"run-{run_id[:8]}.mat"
        saved = tmp_path / download.value.suggested_filename
        download.value.save_as(saved)
        assert csp_blocked(page) == []
    mat = loadmat(saved, simplify_cells=True)
    assert mat["metadata"]["run_id"] == run_id and mat["units"]["load_cell"] == "N"
    assert len(mat["data"]["tow_position"]) == 12
