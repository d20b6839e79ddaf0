"""Cross-check through the API: thruster-driven tow jobs, the estimation+cross-check job,
the fast comparison of two stored results, its plot, and input errors."""

from __future__ import annotations

import logging

import pytest

from tests.api.conftest import AUTH, how_it_ended, start_job, wait_job

#: Slow lane: tows on the simulated rig (in process, simulated time), then cross-check fits.
pytestmark = [pytest.mark.slow, pytest.mark.simtime]


def _completed(client, path: str, body: dict) -> dict:
    job = wait_job(client, start_job(client, path, body), timeout_s=60)
    assert job["state"] == "completed", how_it_ended(job)
    return job


@pytest.fixture(scope="module")
def runs(client) -> dict[str, list[str]]:
    calibration = {"commands": [0.1, 0.3, 0.8], "settle_s": 0.4, "samples_per_step": 3}
    _completed(client, "/api/jobs/calibration", calibration | {"tare_samples": 5})
    short = {"max_time_s": 1.5, "baseline_s": 0.3}
    weight = [
        _completed(client, "/api/jobs/tow", {"force_n": f} | short)["run_ids"][0]
        for f in (24.5, 44.1)
    ]
    thrusters = []
    for f in (20.0, 40.0):
        job = _completed(client, "/api/jobs/tow", {"force_n": f, "drive": "thrusters"} | short)
        assert job["label"].endswith("(thrusters)")
        thrusters += job["run_ids"]
    return {"weight": weight, "thrusters": thrusters}


def test_the_run_detail_offers_the_thrusters_rpm_and_current_with_units(client, runs):
    """What the run detail's channel picker lists: a thruster tow's samples carry each
    thruster's RPM and current with their units; a weight-driven tow's do not."""
    samples = client.get(f"/api/runs/{runs['thrusters'][0]}/samples", headers=AUTH).json()
    assert samples["units"]["thruster1_rpm"] == "rpm"
    assert samples["units"]["thruster2_current"] == "A"
    assert max(samples["channels"]["thruster1_current"][2:]) > 0  # drawn while thrust was on
    weight = client.get(f"/api/runs/{runs['weight'][0]}/samples", headers=AUTH).json()
    assert not any(name.startswith("thruster") for name in weight["channels"])


def _rho(estimation: dict) -> float:
    """|ρ(K_L, K_Q)| of a stored estimation document."""
    names = estimation["correlation"]["names"]
    i, j = names.index("linear_damping"), names.index("quadratic_damping")
    return abs(estimation["correlation"]["matrix"][i][j])


def test_crosscheck_job_then_fast_comparison_of_the_stored_results(client, runs):
    stored = client.get(f"/api/runs/{runs['thrusters'][0]}", headers=AUTH).json()
    assert stored["parameters"]["drive"] == "thrusters"
    assert stored["parameters"]["hung_mass_kg"] is None
    r = client.post(
        "/api/jobs/crosscheck",
        json={"weight_runs": runs["weight"], "thruster_runs": runs["thrusters"]},
        headers=AUTH,
    )
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=120)
    assert job["kind"] == "crosscheck" and job["state"] == "completed", how_it_ended(job)
    out = job["outcome"]
    assert out["axis"] == "surge"
    assert set(out["coefficients"]) == {"inertia", "linear_damping", "quadratic_damping"}
    assert out["thruster_estimation"]["uncertainty"]["calibration_draws"] == 30
    assert out["weight_estimation"]["uncertainty"]["calibration_draws"] == 0
    stuck = [_rho(out[f"{side}_estimation"]) > 0.95 for side in ("weight", "thruster")]
    for name, c in out["coefficients"].items():
        # 1.5 s tows at two forces may not separate K_L from K_Q: then, and only then, no
        # verdict on them, and the damping at the set's speed is compared instead.
        if name != "inertia" and any(stuck):
            assert c["verdict"] == "undecided" and "add a" in c["reason"], c
            combined = out["combined"]["damping_at_speed"]
            if all(stuck):  # compared only when both ran at about the same speed
                assert (
                    combined["verdict"] != "undecided" or "different speeds" in combined["reason"]
                )
            else:
                assert combined["verdict"] != "undecided", combined
        else:
            assert c["verdict"] in ("agree", "marginal", "disagree"), c
    assert out["supply_voltage_v"]["calibration"] > 10 and out["supply_voltage_v"]["runs"] > 10
    assert out["diagnosis"]
    w_id = out["weight_estimation"]["result_id"]
    t_id = out["thruster_estimation"]["result_id"]

    r = client.post(
        "/api/crosscheck", json={"weight_result_id": w_id, "thruster_result_id": t_id}, headers=AUTH
    )
    assert r.status_code == 200, r.text
    fast = r.json()
    assert fast["coefficients"] == out["coefficients"]  # same documents, same comparison
    assert fast["combined"] == out["combined"]
    # The job already cross-checked this pair: asked again, it is that result, not a copy.
    assert fast["result_id"] == out["result_id"] and fast["reused"]
    again = client.post(
        "/api/crosscheck", json={"weight_result_id": w_id, "thruster_result_id": t_id}, headers=AUTH
    ).json()
    assert again["result_id"] == out["result_id"]
    crosschecks = [c["id"] for c in client.get("/api/crosscheck", headers=AUTH).json()]
    assert crosschecks.count(out["result_id"]) == 1
    result = client.get(f"/api/results/{fast['result_id']}", headers=AUTH).json()
    assert result["kind"] == "crosscheck"
    assert sorted(result["run_ids"]) == sorted(runs["weight"] + runs["thrusters"])
    assert result["report_plots"] == ["crosscheck"]
    png = client.get(f"/api/results/{fast['result_id']}/report/crosscheck.png", headers=AUTH)
    assert png.status_code == 200 and png.content.startswith(b"\x89PNG")
    pairs = [
        (c["data"]["weight_result_id"], c["data"]["thruster_result_id"])
        for c in client.get("/api/crosscheck", headers=AUTH).json()
    ]
    assert pairs.count((w_id, t_id)) == 1


def test_crosscheck_input_errors(client, runs):
    calibration = client.get("/api/calibration/latest", headers=AUTH).json()["id"]
    r = client.post(
        "/api/crosscheck",
        json={"weight_result_id": calibration, "thruster_result_id": calibration},
        headers=AUTH,
    )
    assert r.status_code == 422
    assert "weight_result_id: result" in r.json()["detail"]
    assert "allowed: an estimation" in r.json()["detail"]
    r = client.post(
        "/api/crosscheck", json={"weight_result_id": 99999, "thruster_result_id": 1}, headers=AUTH
    )
    assert r.status_code == 422 and "weight_result_id: 99999" in r.json()["detail"]
    r = client.post(
        "/api/jobs/crosscheck",
        json={"weight_runs": ["ffffffffffff"], "thruster_runs": runs["thrusters"]},
        headers=AUTH,
    )
    assert r.status_code == 404
    r = client.post("/api/crosscheck", json={"weight_result_id": 1}, headers=AUTH)
    assert r.status_code == 422
    r = client.post("/api/crosscheck", json={"weight_result_id": 1, "thruster_result_id": 2})
    assert r.status_code == 401


@pytest.mark.parametrize("method", ["ls-raw", "ls-curvefit", "ls-steady"])
def test_a_seed_method_on_thruster_tows_end_to_end(client, runs, method):
    """A seed method (``--method ls-*``) on the rig's thruster tows through the estimation
    job: the thrust calibration's draws reach it as they reach output error; every
    coefficient has a σ and a U, or neither and is named not identified (ls-steady's drag law
    through two runs has no residual to give one); each coefficient further than 2σ of the
    difference from the output-error fit of the same runs is named in the bias warning; and
    the theory comparison, which reads U, is made either way."""
    reference = wait_job(
        client,
        start_job(client, "/api/jobs/estimation", {"run_ids": runs["thrusters"]}),
        timeout_s=120,
    )
    assert reference["state"] == "completed", how_it_ended(reference)
    oe = reference["outcome"]["coefficients"]
    job = wait_job(
        client,
        start_job(client, "/api/jobs/estimation", {"run_ids": runs["thrusters"], "method": method}),
        timeout_s=120,
    )
    assert job["state"] == "completed", how_it_ended(job)
    out = job["outcome"]
    assert out["method"] == method
    assert out["uncertainty"]["calibration_draws"] == 30
    budget = out["budget"]["coefficients"]
    biased = [w for w in out["warnings"] if w.startswith(f"{method} is biased")]
    for name, c in out["coefficients"].items():
        u = budget[name]["expanded_uncertainty"]
        if c["std"] is None:
            assert u is None and name in out["not_identified"], (name, c, u)
            continue
        assert u is not None and u > c["std"] > 0, (name, c, u)
        z = abs(c["value"] - oe[name]["value"]) / (c["std"] ** 2 + oe[name]["std"] ** 2) ** 0.5
        assert (z > 2) == any(f"{name} {c['value']:.4g} against" in w for w in biased), (z, biased)
    if method == "ls-steady":  # two runs, two drag coefficients: no σ, never a round-off one
        assert out["coefficients"]["linear_damping"]["std"] is None
        drag = out["theory"]["dimensionless"]["C_D = 2 K_Q / (ρ A_ref)"]
        assert drag["value"] is not None and drag["expanded_uncertainty"] is None
    assert "added" in out["theory"] or "missing" in out["theory"], out["theory"]


def test_a_curve_method_on_one_drive_level_is_refused_as_bad_input(client, runs, caplog):
    """ls-curvefit on one weight tow: the job ends failed with the refusal itself as its
    error (the run's drive level, what the method needs, what takes one run) — the user's
    choice of method, not "could not fit", and no traceback in the service's log."""
    with caplog.at_level(logging.ERROR, logger="api.core.analysis_worker"):
        job = wait_job(
            client,
            start_job(
                client,
                "/api/jobs/estimation",
                {"run_ids": runs["weight"][:1], "method": "ls-curvefit"},
            ),
            timeout_s=120,
        )
    assert job["state"] == "failed"
    assert job["error"].startswith(
        "runs: drive: got one drive level (24.5 N), allowed: two or more"
    )
    assert "output-error and ls-raw take one run" in job["error"]
    assert not [r for r in caplog.records if job["id"] in r.getMessage()]
