"""Analyses on a Dask distributed cluster (``rig serve --analysis-workers``): the same tasks
and functions as the embedded worker, run by a cluster's worker process; report figures drawn
there come back and are stored by the service; a scheduler nobody runs is one line, exit 2.

The cluster is real: a scheduler and one worker process on loopback (``LocalCluster``), as a
lab runs ``dask scheduler`` and ``dask worker`` on its other machines."""

from __future__ import annotations

import io
import os
import zipfile
from collections.abc import Iterator

import pytest

from tests.api.conftest import AUTH, how_it_ended, wait_job
from tests.support.analysis_watch import Calls
from tests.support.cli import run_in_process

distributed = pytest.importorskip("distributed", reason="the 'cluster' extra is not installed")

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime


@pytest.fixture(scope="module")
def cluster() -> Iterator[str]:
    """A Dask scheduler and one worker process on loopback; yields the scheduler's address."""
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None,
        host="127.0.0.1",
    ) as local:  # fmt: skip
        yield local.scheduler_address


@pytest.fixture
def on_cluster(client, cluster, monkeypatch) -> Iterator[Calls]:
    from api.core.cluster_executor import DaskExecutor

    executor = DaskExecutor(cluster)
    watching = Calls(executor)
    monkeypatch.setattr(client.app.state.runner.analysis, "executor", watching)
    try:
        yield watching
    finally:
        executor.close()


def test_an_estimation_runs_on_the_cluster_and_its_report_is_stored_here(
    client, tow_job, on_cluster
):
    body = {"run_ids": tow_job["run_ids"], "search_effects": False}
    r = client.post("/api/jobs/estimation", json=body, headers=AUTH)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=180)  # the worker imports the fit first
    assert job["state"] == "completed", how_it_ended(job)
    [outcome] = on_cluster.outcomes
    assert outcome.pid in on_cluster.inner.worker_pids() and outcome.pid != os.getpid()
    stored = client.app.state.service.store.result(job["result_id"])
    assert list(stored.run_ids) == tow_job["run_ids"]
    # the figures were drawn on the worker, shipped back and stored by the service
    assert client.app.state.runner.report_names(stored.id)
    report = client.get(f"/api/results/{stored.id}/report.zip", headers=AUTH)
    assert report.status_code == 200, report.text[:200]
    with zipfile.ZipFile(io.BytesIO(report.content)) as zipped:
        assert any(n.endswith("/report.md") for n in zipped.namelist()), zipped.namelist()


def test_a_routes_work_runs_on_the_cluster_and_a_bad_id_is_still_a_404(client, tow_job, on_cluster):
    run_id = tow_job["run_ids"][0]
    r = client.get(f"/api/runs/{run_id}/export?format=parquet", headers=AUTH)
    assert r.status_code == 200 and r.content[:4] == b"PAR1", r.text[:200]
    r = client.post(
        "/api/analysis/sensitivity", json={"vehicle": "seed002-rov", "estimates": [999999]},
        headers=AUTH,
    )  # fmt: skip
    assert r.status_code == 404 and "999999" in r.text  # the worker's error, as on one machine
    assert on_cluster.called == [
        "daq.export_formats.write_export", "api.core.analysis.analyse_vehicle",
    ]  # fmt: skip


def test_serve_with_a_scheduler_nobody_runs_exits_2_naming_the_option(tmp_path):
    argv = ["serve", "--port", "0", "--db", f"sqlite:///{tmp_path / 'rig.db'}",
            "--analysis-workers", "tcp://127.0.0.1:9"]  # fmt: skip
    env = dict(os.environ) | {"XDG_DATA_HOME": str(tmp_path), "RIG_LOCK_DIR": str(tmp_path)}
    done = run_in_process(argv, cwd=tmp_path, env=env)
    assert done.returncode == 2, done.stderr
    assert "--analysis-workers: no Dask scheduler answers at 'tcp://127.0.0.1:9'" in done.stderr
    assert "Traceback" not in done.stderr
