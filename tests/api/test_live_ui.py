"""The Rig page as a new user meets it, in real headless Chromium: against a real ``rig serve``
process (simulated rig, fast pendulum), the link ``rig serve`` prints opens the UI signed in,
a first visit without a token asks without an error and the header stays on one row; the
live plot shows the channel chosen (the pendulum angle moves during a decay) with units,
1-2-5 ticks and the choice kept across a reload. The plot is the page's: its decay runs on the
fast pendulum rig in process on simulated time (a paced service), not in real time."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.api.conftest import signed_in_page
from tests.procedures.test_pendulum import fast_rig_file
from tests.support.cli import run_in_process
from tests.support.serve import stop_service, wait_healthy

# real stack in real time: the slow lane (README, Tests); the fast pendulum's rig service
pytestmark = [pytest.mark.slow, pytest.mark.rig_service(rig="fast-pendulum")]

ROOT = Path(__file__).resolve().parents[2]
PENDULUM = {"start_angle_rad": "0.3", "stop_amplitude_rad": "0.12", "max_time_s": "15"}
# The plotted values of one channel (its key is the trace's `meta`).
TRACE_Y = """key => {
  const t = (document.getElementById('live-plot').data || []).find((d) => d.meta === key);
  return t ? t.y.filter((v) => v !== null) : null;
}"""


class Serve:
    """``rig serve`` as the user runs it, and what it printed."""

    def __init__(self, proc: subprocess.Popen, lines: list[str], token: str, link: str) -> None:
        self.proc, self.lines, self.token, self.link = proc, lines, token, link
        self.url = next(ln for ln in lines if ln.startswith("rig service: ")).split()[2]


@pytest.fixture(scope="module")
def serve(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("live-ui")
    env = os.environ | {"XDG_DATA_HOME": str(tmp), "PYTHONUNBUFFERED": "1"}
    env.pop("RIG_API_TOKEN", None)  # the token is generated into the data directory
    rig = Path(sys.executable).with_name("rig")
    cmd = [str(rig)] if rig.exists() else [sys.executable, "-m", "api.cli.main"]
    rig_file, db = fast_rig_file(tmp), f"sqlite:///{tmp}/rig.db"
    args = ["serve", "--port", "0", "--rig", str(rig_file), "--db", db]
    with open(tmp / "stderr.txt", "w") as err:
        proc = subprocess.Popen(
            [*cmd, *args], cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=err, text=True
        )
    try:
        lines = []
        while not (lines and lines[-1].startswith("browser UI: ")):
            line = proc.stdout.readline()
            assert line, f"rig serve ended: {lines} {(tmp / 'stderr.txt').read_text()}"
            lines.append(line.rstrip("\n"))
        token = (tmp / "towrig" / "api-token").read_text().strip()
        assert not any(token in line for line in lines), lines  # never in its output
        port = lines[0].split()[2].rstrip("/").rsplit(":", 1)[1]
        # the link, printed only when asked for (a light command: in this process,
        # tests/support/cli.py)
        asked = run_in_process(["token", "--link", "--port", port], cwd=ROOT, env=env)
        assert asked.returncode == 0, asked.stderr
        link = asked.stdout.strip()
        service = Serve(proc, lines, token, link)
        wait_healthy(proc, service.url, (tmp / "stderr.txt").read_text, timeout_s=20)
        yield service
    finally:
        stop_service(proc)


def test_the_token_link_carries_the_token_and_opens_the_ui_signed_in(chromium, serve):
    from playwright.sync_api import expect

    assert serve.link.startswith("http://127.0.0.1:") and "<token>" not in serve.link
    assert serve.link.endswith(f"/#token={serve.token}")
    with chromium.page() as page:
        page.goto(serve.link)
        expect(page.locator("#conn-text")).to_contain_text("simulated")
        expect(page.locator("#token-dialog")).to_be_hidden()
        assert "token=" not in page.url  # gone from the address bar and the history entry
        assert page.evaluate("localStorage.getItem('rig-token')") == serve.token
        with page.expect_response(lambda r: "/api/runs?" in r.url) as runs:
            page.click("nav a[data-page=runs]")
        assert runs.value.status == 200
        expect(page.locator("#token-dialog")).to_be_hidden()

        # the link pasted into a tab already asking for the token (no reload: a hash change)
        page.evaluate("localStorage.clear()")
        page.goto(serve.url)
        expect(page.locator("#token-dialog")).to_be_visible()
        expect(page.locator("#conn-text")).to_have_text("waiting for the API token")
        page.goto(serve.link)
        expect(page.locator("#conn-text")).to_contain_text("simulated")
        # answers to requests sent before the token arrived do not bring the dialog back
        page.wait_for_function(
            "() => Number(document.querySelector('#live-count').textContent) > 20"
        )
        expect(page.locator("#token-dialog")).to_be_hidden()
        assert page.text_content("#token-error") == ""


def test_a_first_visit_asks_for_the_token_without_an_error_and_the_nav_is_one_row(chromium, serve):
    from playwright.sync_api import expect

    with chromium.page() as page:
        with page.expect_response(lambda r: r.url.endswith("/api/rig")) as first:
            page.goto(serve.url)
        assert first.value.status == 401  # the page asked the API and was told no
        expect(page.locator("#token-dialog")).to_be_visible()
        # the page has handled that 401 (the status shows it) and says nothing was refused
        expect(page.locator("#conn-text")).to_have_text("waiting for the API token")
        assert page.text_content("#token-error") == ""

        _header_is_one_row(page)
        page.fill("#token-input", "not-the-token")
        page.click("#token-form button[type=submit]")
        expect(page.locator("#token-error")).to_contain_text("refused")
        page.fill("#token-input", serve.token)
        page.click("#token-form button[type=submit]")
        expect(page.locator("#token-dialog")).to_be_hidden()
        expect(page.locator("#conn-text")).to_contain_text("simulated")
        expect(page.locator("#who")).to_be_visible()  # who is signed in, and Sign out
        _header_is_one_row(page)


def _header_is_one_row(page) -> None:
    """At 1280 and 1024 px the header's visible items and links sit on one row, in the
    window."""
    for width in (1280, 1024):
        page.set_viewport_size({"width": width, "height": 800})
        tops = page.eval_on_selector_all(
            "header > :not([hidden]), nav a",
            "els => els.map((e) => e.getBoundingClientRect().top)",
        )
        header = page.eval_on_selector("header", "h => h.getBoundingClientRect().height")
        assert header < 60, (width, header)  # one row, not two
        assert max(tops) - min(tops) < 10, (width, tops)
        assert page.evaluate("document.documentElement.scrollWidth") <= width


def test_chosen_channels_are_plotted_live_with_units_and_kept(chromium, client, service):
    from playwright.sync_api import expect

    with signed_in_page(chromium, service, client) as page:
        expect(page.locator("#conn-text")).to_contain_text("simulated")
        chip = page.locator("#live-channels input[value=pendulum_angle]")
        expect(chip).to_be_visible()  # every channel of the rig file is offered
        expect(page.locator("#live-channels")).to_contain_text("load cell N")
        expect(page.locator("#live-channels input[value=thruster_1]")).to_have_count(1)
        expect(chip).not_to_be_checked()  # idle: the tow defaults

        page.click(".tabs button[data-form=pendulum]")
        for name, value in PENDULUM.items():
            page.fill(f"#form-pendulum [name={name}]", value)
        page.click("#form-pendulum button[type=submit]")
        expect(page.locator("#job-state")).to_have_text("running")
        # a pendulum test shows its angle by default, and only that
        expect(page.locator("#live-kind")).to_have_text("pendulum")
        expect(chip).to_be_checked()
        expect(page.locator("#live-channels input:checked")).to_have_count(1)

        # the user adds the load cell: a second row in newtons
        page.check("#live-channels input[value=load_cell]")
        page.wait_for_function(f"() => ({TRACE_Y})('load_cell') !== null")
        # the angle moves: released at 0.3 rad it swings through zero
        page.wait_for_function(
            f"() => {{ const y = ({TRACE_Y})('pendulum_angle');"
            " return y && Math.max(...y) - Math.min(...y) > 0.2; }",
            timeout=40_000,
        )
        layout = page.evaluate("document.getElementById('live-plot').layout")
        titles = [layout[k]["title"]["text"] for k in ("yaxis", "yaxis2")]
        assert sorted(titles) == ["load cell [N]", "pendulum angle [rad]"]  # a row per unit
        assert layout["xaxis"]["title"]["text"] == "time [s]"
        for axis in ("yaxis", "yaxis2"):
            step = layout[axis]["dtick"]
            mantissa = step / 10 ** math.floor(math.log10(step) + 1e-9)
            assert round(mantissa, 6) in (1, 2, 5), (axis, step)
            lo, hi = layout[axis]["range"]
            assert 3 <= (hi - lo) / step <= 12, layout[axis]

        final = "el => ['completed', 'aborted', 'failed'].includes(el.textContent)"
        page.wait_for_selector("#job-state", state="attached")
        page.wait_for_function(
            f"() => ({final})(document.querySelector('#job-state'))", timeout=40_000
        )
        assert page.text_content("#job-state") == "completed", page.text_content("#job-panel")
        # a stale report of the job still running (a status poll answered before its end,
        # read after the stream's final event) does not bring the panel back
        page.evaluate(
            "() => Promise.all([import('/static/jobs.js'), import('/static/state.js')])"
            ".then(([jobs, { state }]) => jobs.showJob({ ...state.job, state: 'running' }))"
        )
        assert page.text_content("#job-state") == "completed"

        page.reload()  # the choice for pendulum tests is kept
        expect(page.locator("#live-kind")).to_have_text("pendulum")
        expect(page.locator("#live-channels input[value=load_cell]")).to_be_checked()
        expect(page.locator("#live-channels input[value=pendulum_angle]")).to_be_checked()
