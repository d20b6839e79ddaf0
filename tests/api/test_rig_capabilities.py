"""The API on a minimal rig (an encoder and a brake, no thrusters): ``GET /api/rig`` says
what it can do and why not the rest, a job it cannot do is a 409 naming what is missing,
and the weight-driven tow it can do runs on the simulated rig."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.api.conftest import AUTH, TOKEN, how_it_ended, start_job, wait_job

ENCODER_TOW = Path(__file__).resolve().parents[2] / "fixtures/rigs/encoder-tow.toml"
pytestmark = pytest.mark.rig_service(rig=ENCODER_TOW)


def test_get_rig_lists_capabilities_with_reasons_and_the_safety_channels(client):
    rig = client.get("/api/rig", headers=AUTH).json()
    caps = rig["capabilities"]
    assert caps["tow"]["available"] is True
    assert caps["tow"]["drives"]["thrusters"] == {
        "available": False,
        "reason": "tow with thrusters: needs a [thrusters] section",
        "drives": None,
    }
    assert caps["spin"]["available"] is False
    assert "needs channel yaw_angle, channel spin_release" in caps["spin"]["reason"]
    assert caps["thrust_calibration"]["available"] is False
    assert rig["safety"]["end_of_travel"]["available"] is False
    assert "max_distance_m" in rig["safety"]["end_of_travel"]["reason"]
    assert "max_torque_nm" not in rig["limits"]  # not in the rig file: not offered
    assert rig["thrusters"]["state"] == "absent"
    assert set(rig["sample"]["channels"]) == {"tow_position", "tow_release"}


@pytest.mark.parametrize(
    ("path", "body", "says"),
    [
        ("/api/jobs/spin", {"torque_nm": 0.3}, "spin: needs channel yaw_angle"),
        (
            "/api/jobs/tow",
            {"force_n": 5.0, "drive": "thrusters"},
            "tow with thrusters: needs a [thrusters] section",
        ),
        ("/api/jobs/calibration", {}, "thrust_calibration: needs channel load_cell"),
        ("/api/rig/arm", None, "arming: needs a [thrusters] section"),
    ],
)
def test_what_the_rig_cannot_do_is_a_409_naming_what_is_missing(client, path, body, says):
    r = client.post(path, json=body, headers=AUTH)
    assert r.status_code == 409, r.text
    assert says in r.json()["detail"]
    assert r.json()["detail"].startswith("rig 'Encoder tow rig' cannot do this: ")


def test_a_weight_tow_on_the_minimal_rig_completes_by_distance(client):
    job_id = start_job(client, "/api/jobs/tow", {"force_n": 9.8, "max_distance_m": 0.3})
    job = wait_job(client, job_id, timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    (run_id,) = job["run_ids"]
    run = client.get(f"/api/runs/{run_id}", headers=AUTH).json()
    assert run["channel_names"] == ["tow_position", "tow_release"]
    assert run["sample_count"] > 10 and run["status"] == "completed"
    samples = client.get(f"/api/runs/{run_id}/samples", headers=AUTH).json()
    position = samples["channels"]["tow_position"]
    assert position[-1] >= 0.3  # stopped by distance (this rig has no end-of-travel switch)
    csv = client.get(f"/api/runs/{run_id}/export?format=csv", headers=AUTH)
    assert csv.status_code == 200 and "tow_position" in csv.text


def test_the_live_stream_carries_the_rigs_two_channels_and_no_thrusters(live_url):
    samples = []
    with live_url.stream("GET", "/api/stream?max_s=1.5&jobs=false") as r:
        assert r.status_code == 200
        kind = None
        for line in r.iter_lines():
            if line.startswith("event: "):
                kind = line[7:]
            elif line.startswith("data: ") and kind == "sample":
                samples.append(json.loads(line[6:]))
    assert len(samples) >= 5
    assert all(set(s["channels"]) == {"tow_position", "tow_release"} for s in samples)
    assert all(not s.get("thrusters") for s in samples)


def test_the_page_offers_only_what_the_rig_can_do_and_says_why(chromium, live_url):
    from playwright.sync_api import expect

    with chromium.page() as page:
        page.goto(f"{live_url.base_url}#token={TOKEN}")
        expect(page.locator("#conn-text")).to_contain_text("Encoder tow rig")
        expect(page.locator(".tabs button[data-form=spin]")).to_have_class("unavailable")
        expect(page.locator(".tabs button[data-form=tow]")).not_to_have_class("unavailable")
        # tow: the weight drive only, the thruster drive greyed out with its reason
        expect(page.locator("#form-tow .capability-reason")).to_contain_text(
            "tow with thrusters: needs a [thrusters] section"
        )
        drives = page.eval_on_selector_all(
            "#form-tow select[name=drive] option", "os => os.map(o => [o.value, o.disabled])"
        )
        assert drives == [["weight", False], ["thrusters", True]]
        assert page.locator("#start-tow").is_enabled()
        page.click(".tabs button[data-form=spin]")
        expect(page.locator("#form-spin .capability-reason")).to_contain_text(
            "spin: needs channel yaw_angle"
        )
        assert page.locator("#form-spin button[type=submit]").is_disabled()
        assert page.locator("#arm-btn").is_disabled()
