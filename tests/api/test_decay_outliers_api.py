"""``exclude_outliers`` on free decays, through every face: five heave decays of one body
imported over HTTP (``POST /api/runs/import?kind=decay``), released from one amplitude, the
third with 30 % more linear damping (a touch on the model, a wave left in the tank).
Chauvenet flags it either way (its logarithmic decrement 0.33 against the others' 0.25);
only with ``exclude_outliers`` is it left out of the fit, and then the result, the stored
result's runs, the warnings and the report all say so (docs/uncertainty.md). The same
through ``rig estimate --exclude-outliers``. Data: scipy ``solve_ivp`` decays
(``tests.integration.test_decay_import.heave_decay``), not our integrator; the tows' own
test is ``test_repeat_outliers_api.py``."""

from __future__ import annotations

import io
import zipfile

import pytest

from tests.api.conftest import AUTH, completed_estimation
from tests.integration.test_decay_import import heave_decay
from tests.support.cli import RigCliText, printed_json

#: The ten uploads are imported in a worker thread (``imports_in_a_thread``): this module is
#: about ``exclude_outliers``; the upload's child process is tested where it is the subject.
pytestmark = pytest.mark.usefixtures("imports_in_a_thread")

CSV = {"Content-Type": "text/csv"}
BODY_KG = 1000.0  # released from 0.05 m: the 0.1 mm noise is 0.2 % of the amplitude
SCALES = (1.0, 1.0, 1.3, 1.0, 1.0)  # the third decay's damping × 1.3
WRONG = SCALES.index(1.3)


def _decays(tmp_path) -> tuple[list[bytes], dict[str, float]]:
    """The five decays' CSV bytes and the four alike's truth."""
    files, truth = [], {}
    for i, scale in enumerate(SCALES):
        path = tmp_path / f"heave{i}.csv"
        made = heave_decay(path, BODY_KG, seed=10 + i, damping_scale=scale)
        truth = made if scale == 1.0 else truth
        files.append(path.read_bytes())
    return files, truth


def _estimate(client, run_ids, **extra) -> dict:
    return completed_estimation(client, run_ids, timeout_s=180, **extra)


def _report_md(client, result_id: int) -> str:
    r = client.get(f"/api/results/{result_id}/report.zip", headers=AUTH)
    assert r.status_code == 200, r.text
    with zipfile.ZipFile(io.BytesIO(r.content)) as zipped:
        name = next(n for n in zipped.namelist() if n.endswith("report.md"))
        return zipped.read(name).decode("utf-8")


def _outlier_warnings(outcome: dict) -> list[str]:
    return [w for w in outcome["warnings"] if "outlier among the repeats" in w]


def test_a_flagged_decay_is_left_out_only_when_the_request_says_so(client, tmp_path):
    files, truth = _decays(tmp_path)
    query = (f"kind=decay&dof=heave&stiffness={truth['stiffness']:g}&known_inertia={BODY_KG:g}"
             "&release_time_s=1")  # fmt: skip
    run_ids = []
    for i, body in enumerate(files):
        r = client.post(
            f"/api/runs/import?{query}&filename=heave{i}.csv", content=body, headers=AUTH | CSV
        )
        assert r.status_code == 201, r.text
        run_ids.append(r.json()["run_id"])
    wrong = run_ids[WRONG]

    kept = _estimate(client, run_ids)["outcome"]
    (condition,) = kept["repeats"]["conditions"]  # one amplitude: one condition of five
    assert condition["n"] == 5 and condition["unit"] == "1"
    assert kept["repeats"]["outliers"] == [wrong] and kept["repeats"]["excluded"] == []
    assert kept["runs"] == run_ids
    (warning,) = _outlier_warnings(kept)
    assert warning.startswith(f"record {wrong} is an outlier") and "kept in the fit" in warning
    stored = client.get(f"/api/results/{kept['result_id']}", headers=AUTH).json()
    assert stored["run_ids"] == run_ids
    assert f"{wrong} (kept)" in _report_md(client, kept["result_id"])

    dropped_job = _estimate(client, run_ids, exclude_outliers=True)
    assert dropped_job["parameters"]["exclude_outliers"] is True
    dropped = dropped_job["outcome"]
    assert dropped["repeats"]["outliers"] == [wrong] and dropped["repeats"]["excluded"] == [wrong]
    fitted = [r for r in run_ids if r != wrong]
    assert dropped["runs"] == fitted
    assert list(dropped["window"]) == fitted
    (warning,) = _outlier_warnings(dropped)
    assert warning.startswith(f"record {wrong} is an outlier") and "left out of the fit" in warning
    stored = client.get(f"/api/results/{dropped['result_id']}", headers=AUTH).json()
    assert stored["run_ids"] == fitted  # the stored result is of the runs fitted, as a tow's
    report = _report_md(client, dropped["result_id"])
    assert f"{wrong} (left out)" in report
    assert f"Left out of the fit at the user's request (exclude_outliers): {wrong}." in report
    # every kind's report gets the budget, and the repeats once
    assert "## Uncertainty (ITTC 7.5-02-01-01 / GUM, 95 %)" in report
    assert report.count("Repeat runs") == 1 and "repeatability (4 repeat campaigns" in report
    # the four alike give their damping (the kept fit is pulled 4 % off by the fifth)
    damping = truth["damping"]
    assert dropped["coefficients"]["linear_damping"]["value"] == pytest.approx(damping, rel=0.005)
    assert kept["coefficients"]["linear_damping"]["value"] > 1.02 * damping


def test_rig_estimate_exclude_outliers_leaves_the_flagged_decay_out(tmp_path):
    files, truth = _decays(tmp_path)
    rig = RigCliText(tmp_path)
    given = ("--kind", "decay", "--dof", "heave", "--stiffness", f"{truth['stiffness']:g}",
             "--known-inertia", f"{BODY_KG:g}", "--release-time", "1")  # fmt: skip
    run_ids = [rig("import", f"heave{i}.csv", *given) for i in range(len(files))]
    wrong = run_ids[WRONG]
    out = rig("estimate", *run_ids, "--no-effects", "--exclude-outliers")
    assert f"warning: record {wrong} is an outlier" in out and "left out of the fit" in out
    assert f"left out (--exclude-outliers): {wrong}" in out
    assert "from 4 run(s)" in out.splitlines()[0]
    data = printed_json(rig("estimate", *run_ids, "--no-effects", "--json"))
    assert data["repeats"]["outliers"] == [wrong] and data["repeats"]["excluded"] == []
    assert wrong in data["runs"]
