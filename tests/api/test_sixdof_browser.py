"""The 6-DOF page in real headless Chromium: pick the seed 002 ROV, command a pure yaw
turn through its thrusters, see the plots, the steady values and the allocation matrix."""

from __future__ import annotations

import pytest

from api.http.app import create_app
from tests.api.conftest import TOKEN, LiveServer

#: Slow lane: a browser per page (tests/api/test_browser.py stays in the fast lane).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def page_url(chromium, client, service):
    app = create_app(service, token=TOKEN, manage_service=False, runner=client.app.state.runner)
    with LiveServer(app) as live, chromium.page() as pg:
        yield pg, live.url


def test_sixdof_page_simulates_a_yaw_turn(page_url, service):
    from playwright.sync_api import expect

    # a free decay's stored result is offered for its DOF (it names its dof, not an axis)
    run = service.store.create_run(kind="decay", parameters={}, channel_names=["decay_position"],
                                   rig_name="r", vehicle="seed002-rov", rig_toml="")  # fmt: skip
    doc = {"kind": "decay", "dof": "heave", "method": "output-error", "coefficients": {},
           "runs": [run]}  # fmt: skip
    result_id = service.store.add_result([run], "estimation", doc)
    page, url = page_url
    page.goto(f"{url}/#token={TOKEN}")
    page.click("nav a[data-page=sixdof]")
    offered = page.locator(f"#sixdof-estimates label:has(input[value='{result_id}'])")
    expect(offered).to_contain_text(f"#{result_id} heave free decay / output-error")
    page.select_option("#sixdof-vehicle", "seed002-rov")
    expect(page.locator("#sixdof-commands input")).to_have_count(8)
    expect(page.locator("#sixdof-alloc tbody tr")).to_have_count(6)
    for i, u in enumerate(("-0.5", "0.5", "-0.5", "0.5")):  # seed 002's w_φ
        page.fill(f"#sixdof-form [name=u{i}]", u)
    page.fill("#sixdof-form [name=duration_s]", "40")
    expect(page.locator("#sixdof-empty")).to_contain_text("press Simulate")  # not a blank panel
    page.click("#sixdof-form button[type=submit]")
    expect(page.locator("#sixdof-empty")).to_be_hidden()
    expect(page.locator("#sixdof-status")).to_contain_text("40 s simulated")
    expect(page.locator("#sixdof-steady")).to_contain_text("Settled")
    expect(page.locator("#sixdof-linear .main-svg").first).to_be_visible()
    expect(page.locator("#sixdof-track .main-svg").first).to_be_visible()
    # N = 4 · 0.5 · 2.4336 · |ρ × d| = 1.298 N·m about z up, i.e. r < 0 (z down):
    # K_L r + K_Q r² = N gives |r| = 0.54851 rad/s
    expect(page.locator("#sixdof-steady")).to_contain_text("-0.54851")
    # the form is not mistaken for a "start a test" form (that would POST /api/jobs/undefined)
    expect(page.locator("#sixdof-file-errors li")).to_have_count(0)

    page.fill("#sixdof-form [name=u0]", "1.5")  # over max_command: the server says which
    page.click("#sixdof-form button[type=submit]")
    expect(page.locator("#sixdof-status .error")).to_contain_text("thruster '1'")
