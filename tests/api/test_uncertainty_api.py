"""GET /api/sequences/{name}/uncertainty: the pre-test prediction over HTTP, from stored
estimates named in the request; 404 for an unknown file, 422 naming an axis without a model."""

from __future__ import annotations

from tests.api.conftest import AUTH
from tests.support.analysis_watch import Calls

SURGE = {"inertia": 143.26, "linear_damping": 20.16, "quadratic_damping": 241.14}
YAW = {"inertia": 7.97, "linear_damping": 0.119, "quadratic_damping": 4.12}


def _stored(store, run_ids, axis, values):
    doc = {
        "axis": axis,
        "method": "output-error",
        "coefficients": {k: {"value": v, "std": 0.0} for k, v in values.items()},
    }
    return store.add_result(run_ids, "estimation", doc)


def test_pretest_route_predicts_u_for_the_seed_campaign(client, tow_job, monkeypatch):
    store = client.app.state.service.store
    analysis = client.app.state.runner.analysis
    calls = Calls(analysis.executor_for(store))
    monkeypatch.setattr(analysis, "executor", calls)
    surge = _stored(store, tow_job["run_ids"], "surge", SURGE)
    yaw = _stored(store, tow_job["run_ids"], "yaw", YAW)
    url = "/api/sequences/seed000-campaign/uncertainty"
    r = client.get(f"{url}?result={surge}&result={yaw}&release_std_s=0.0003", headers=AUTH)
    assert r.status_code == 200, r.text
    axes = r.json()["axes"]
    inertia = axes["surge"]["coefficients"]["inertia"]
    assert calls.called == ["api.core.pretest.predict_sequence"]  # in the worker process
    assert inertia["reported"].startswith("143.")
    assert 0.1 < inertia["expanded_uncertainty"] < 5  # the declared Type B sources' size
    assert axes["yaw"]["coefficients"]["inertia"]["dominant_source"].startswith("spin_drum")
    only_surge = client.get(f"{url}?result={surge}", headers=AUTH)
    assert only_surge.status_code == 422 and "no stored estimate for yaw" in only_surge.text
    assert client.get(f"{url.replace('seed000', 'nope')}", headers=AUTH).status_code == 404
    assert client.get(f"{url}?release_std_s=5", headers=AUTH).status_code == 422
    assert client.get(f"{url}?result=999999999", headers=AUTH).status_code == 404
