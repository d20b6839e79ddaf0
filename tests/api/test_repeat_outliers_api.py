"""``POST /api/jobs/estimation`` with ``exclude_outliers``: five repeats of one tow, the fifth
pulled 6 % harder than its declared force (a wrong weight hung). Chauvenet flags it either
way; only with ``exclude_outliers`` is it left out of the fit (docs/uncertainty.md). Data:
scipy ``solve_ivp`` runs (``tests.estimation.synth``), not our simulator."""

from __future__ import annotations

import numpy as np

from daq.csv_to_store import import_csv
from tests.api.conftest import AUTH, completed_estimation
from tests.estimation.synth import SURGE_TRUTH, Physics, weight_run

FORCE_N = 24.5


def _import_repeats(store, tmp_path) -> list[str]:
    rng = np.random.default_rng(7)
    phys = Physics(*SURGE_TRUTH)
    ids = []
    for i, pulled in enumerate((FORCE_N,) * 4 + (FORCE_N * 1.06,)):
        run = weight_run(phys, pulled, run_id=f"r{i}", rng=rng)
        path = tmp_path / f"tow{i}.csv"
        rows = "\n".join(f"{t:.4f},{x:.4f}" for t, x in zip(run.t, run.position, strict=True))
        path.write_text("t,position\n" + rows + "\n", encoding="utf-8")
        ids.append(
            import_csv(store, path, kind="tow", parameters={"force_n": FORCE_N}, release_time_s=1.0)
        )
    return ids


def _estimate(client, run_ids, **extra) -> dict:
    return completed_estimation(client, run_ids, timeout_s=120, **extra)


def test_a_flagged_repeat_is_left_out_only_when_the_request_says_so(client, tmp_path):
    run_ids = _import_repeats(client.app.state.service.store, tmp_path)
    wrong = run_ids[-1]

    kept = _estimate(client, run_ids)
    assert kept["outcome"]["repeats"]["outliers"] == [wrong]
    assert kept["outcome"]["repeats"]["excluded"] == []
    assert wrong in kept["outcome"]["runs"]

    dropped = _estimate(client, run_ids, exclude_outliers=True)
    assert dropped["parameters"]["exclude_outliers"] is True
    assert dropped["outcome"]["repeats"]["excluded"] == [wrong]
    assert wrong not in dropped["outcome"]["runs"]
    stored = client.get(f"/api/results/{dropped['outcome']['result_id']}", headers=AUTH).json()
    assert stored["run_ids"] == [r for r in run_ids if r != wrong]  # the runs fitted
    inertia = dropped["outcome"]["coefficients"]["inertia"]["value"]
    assert abs(inertia - SURGE_TRUTH[0]) < abs(
        kept["outcome"]["coefficients"]["inertia"]["value"] - SURGE_TRUTH[0]
    )
