"""A campaign over HTTP on the simulated rig (simulated time): it queues the tests it
chooses as ordinary tow jobs, re-estimates after each, keeps its trail (choice, why,
uncertainty before and after) on the job, tags its runs, and stops at its budget."""

from __future__ import annotations

import pytest

from api.core import campaign
from tests.api.conftest import AUTH, how_it_ended, wait_job, wait_rig_free

pytestmark = pytest.mark.simtime


def test_a_campaign_runs_its_choices_as_jobs_and_keeps_the_trail(
    client, service, monkeypatch
) -> None:
    # The campaign goes on as each of its jobs ends, woken by the job's end: with an hour
    # between its looks at the job (which are for a stop) it still finishes in time.
    monkeypatch.setattr(campaign, "POLL_S", 3600.0)
    wait_rig_free(client)
    body = {"target_percent": 1, "axes": ["surge"], "max_runs": 2, "max_minutes": 30}
    r = client.post("/api/campaigns", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=240)
    assert job["kind"] == "campaign" and job["state"] == "completed", how_it_ended(job)
    doc = job["outcome"]
    trail = doc["trail"]
    # a budget of 2 runs: the target (U ≤ 1 %, all separated) is not reachable with one
    # tow, so the campaign made exactly two and said which limit stopped it (the rig
    # file's ±5 g hung weights alone give K_L's U 3.7 %: out of reach)
    assert doc["runs_used"] == 2 and len(trail) == 2, doc
    assert doc["outcome"] in ("target", "budget: 2 of 2 runs used") or doc["outcome"].startswith(
        "target out of reach: on surge the declared tolerances alone give linear_damping"
    ), doc["outcome"]
    first, second = trail
    assert first["before"]["unresolved"] == ["no fit yet"]
    assert set(first["after"]["expanded_percent"]) == {
        "inertia",
        "linear_damping",
        "quadratic_damping",
    }
    assert second["before"] == first["after"]  # the trail is continuous
    assert "reduction" in second["why"] or "separated" in second["why"]
    assert second["tank_minutes"] > first["tank_minutes"] > 0
    for entry in trail:  # each a tow within the rig file's 100 N, with its operator's acts
        assert 0 < abs(entry["request"]["force_n"]) <= 100
        assert "hang" in entry["instructions"]
        run = service.store.get_run(entry["run_id"])
        assert run.metadata["campaign"] == job["id"]
        job_end = wait_job(client, entry["job_id"])
        assert job_end["state"] == "completed", how_it_ended(job_end)
    assert job["run_ids"] == [e["run_id"] for e in trail]
    listed = client.get("/api/campaigns", headers=AUTH).json()
    assert job["id"] in [c["id"] for c in listed]


def test_a_pendulum_campaign_chooses_its_releases_and_keeps_the_trail(client, service) -> None:
    """The swing axis (pendulum) is planned like the others: its opening at half the rig
    file's largest release (0.5 rad), then a release chosen from the fit and its budget, each
    an ordinary pendulum job with the operator's acts, each fit stored with its U."""
    wait_rig_free(client)
    body = {"target_percent": 0.02, "axes": ["swing"], "max_runs": 2, "max_minutes": 30}
    r = client.post("/api/campaigns", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=240)
    assert job["state"] == "completed", how_it_ended(job)
    doc = job["outcome"]
    first, second = doc["trail"]
    assert first["request"] == {"start_angle_rad": 0.25} and "opening" in first["why"]
    assert first["command"] == "rig pendulum --angle 0.25"
    # each coefficient as the pendulum's result names it (its inertia is the added mass α)
    assert set(first["after"]["expanded_percent"]) == {
        "added_mass",
        "linear_damping",
        "quadratic_damping",
    }
    # K_Q's U (≈ 0.03 %) above the 0.02 % target after the opening: a release chosen on it
    assert second["before"] == first["after"] and "quadratic_damping" in second["why"]
    assert "per tank minute" in second["why"] and second["predicted_after"] is not None
    assert 0.25 < second["request"]["start_angle_rad"] <= 0.5
    after = second["after"]["expanded_percent"]["quadratic_damping"]
    assert after < first["after"]["expanded_percent"]["quadratic_damping"]
    assert doc["outcome"] in ("target", "budget: 2 of 2 runs used"), doc["outcome"]
    for entry in (first, second):
        assert "pull it out to" in entry["instructions"]
        assert service.store.get_run(entry["run_id"]).metadata["campaign"] == job["id"]
        (stored,) = [
            res
            for res in service.store.results(entry["run_id"], kind="estimation")
            if res.data.get("campaign") and entry["run_id"] == res.run_ids[-1]
        ]
        assert stored.data["kind"] == "pendulum" and stored.data["budget"]["coefficients"]


def test_a_campaign_refuses_a_bad_target_naming_the_field(client) -> None:
    r = client.post("/api/campaigns", json={"target_percent": 0}, headers=AUTH)
    assert r.status_code == 422 and "target_percent" in r.text
    r = client.post("/api/campaigns", json={"axes": ["heave"]}, headers=AUTH)
    assert r.status_code == 422 and "axes" in r.text


def test_a_campaign_is_stopped_before_its_next_choice(client) -> None:
    wait_rig_free(client)
    client.post("/api/queue/pause", headers=AUTH)  # its first tow waits in the queue
    body = {"axes": ["surge"], "max_runs": 5}
    job = client.post("/api/campaigns", json=body, headers=AUTH).json()
    r = client.post(f"/api/campaigns/{job['id']}/stop", headers=AUTH)
    assert r.status_code == 200, r.text
    ended = wait_job(client, job["id"], timeout_s=60)
    assert ended["state"] == "aborted" and ended["outcome"]["outcome"] == "stopped by the operator"
    assert ended["outcome"]["trail"] == []
    assert client.get("/api/queue", headers=AUTH).json()["jobs"] == []  # its tow went too
    client.post("/api/queue/resume", headers=AUTH)
    again = client.post(f"/api/campaigns/{job['id']}/stop", headers=AUTH)
    assert again.status_code == 409


def test_the_services_estimation_advice_stays_within_the_rig_file(client) -> None:
    """Two tows at nearly the same force cannot separate K_L from K_Q; the advice (from the
    planner, with the rig file's envelope) names a force the rig can pull: ≤ max_force_n
    100 N, never 2× the highest (180 N)."""
    import re

    from tests.api.conftest import completed_tows

    runs = completed_tows(client, [80.0, 90.0])
    body = {"run_ids": runs, "method": "output-error", "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)
    warnings = job["outcome"]["warnings"]
    (advice,) = [w for w in warnings if "K_L and K_Q" in w]
    forces = [float(x) for x in re.findall(r"rig tow --force (-?[0-9.]+)", advice)]
    assert forces and all(0 < f <= 100.0 for f in forces), advice
    assert all(max(f / d, d / f) >= 1.5 for f in forces for d in (80.0, 90.0)), advice
    assert "180" not in advice


def test_a_campaign_is_refused_after_an_emergency_stop_until_acknowledged(client) -> None:
    wait_rig_free(client)
    assert client.post("/api/rig/emergency-stop").status_code == 200
    r = client.post("/api/campaigns", json={"axes": ["surge"]}, headers=AUTH)
    assert r.status_code == 409 and "emergency stop" in r.json()["detail"], r.text
    assert client.post("/api/estop/ack", json={"note": "checked"}, headers=AUTH).status_code == 200
    client.post("/api/queue/resume", headers=AUTH)


def test_a_campaigns_fit_runs_in_the_analysis_worker_process(client, monkeypatch) -> None:
    """The fit after each run (seconds of CPU, 170 MB) runs where estimation jobs run: in
    the niced worker process, never in the rig service's process beside the clock."""
    import os

    from api.core.analysis_executor import ANALYSIS_NICENESS
    from tests.api.test_analysis_process import Watching

    analysis = client.app.state.runner.analysis
    watched = Watching(analysis.executor_for(client.app.state.service.store))
    monkeypatch.setattr(analysis, "executor", watched)
    wait_rig_free(client)
    body = {"target_percent": 1, "axes": ["surge"], "max_runs": 1, "max_minutes": 30}
    job = wait_job(
        client, client.post("/api/campaigns", json=body, headers=AUTH).json()["id"], timeout_s=240
    )
    assert job["state"] == "completed" and job["outcome"]["runs_used"] == 1, how_it_ended(job)
    [outcome] = watched.outcomes
    assert outcome.error is None, outcome.traceback
    assert outcome.pid != os.getpid() and outcome.niceness >= ANALYSIS_NICENESS
    fit = outcome.data["fit"]
    stored = client.app.state.service.store.result(fit.result_id)
    assert list(stored.run_ids) == job["run_ids"] and stored.data["campaign"] is True
    assert set(fit.state.values) >= {"inertia", "linear_damping", "quadratic_damping"}


def test_a_service_that_stops_ends_its_campaign_saying_so(tmp_path, caplog) -> None:
    """Stopping the service ends a running campaign ``aborted: the service stopped`` and
    its ending is stored before the job registry closes (no write after it closed)."""
    import logging

    from fastapi.testclient import TestClient

    from api.http.app import create_app
    from daq.session import RigSource
    from daq.store import Store
    from daq.store.job_repository import JobRepository
    from tests.api.conftest import TOKEN, simulated_service

    url = f"sqlite:///{tmp_path / 'rig.db'}"
    service = simulated_service(RigSource.load(), url)
    with caplog.at_level(logging.WARNING), TestClient(create_app(service, token=TOKEN)) as c:
        c.post("/api/queue/pause", headers=AUTH)  # its first tow waits in the queue
        body = {"axes": ["surge"], "max_runs": 5}
        job_id = c.post("/api/campaigns", json=body, headers=AUTH).json()["id"]
        wait_job(c, job_id, states=("running",))
    with Store(url) as store:
        row = JobRepository(store).get(job_id)
    assert row is not None
    assert row["state"] == "aborted", how_it_ended(row)
    assert row["message"].startswith("the service stopped"), row
    assert "cannot schedule new futures" not in caplog.text
