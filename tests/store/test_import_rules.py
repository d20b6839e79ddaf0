"""An import checks what it is told (``api.core.imports`` and ``daq.csv_to_store.import_csv``):
a towrig export imports back from its own header, the rig file's limits and the direction
of motion bound the drive, one-row files are refused, and a release may precede the record."""

from __future__ import annotations

import io

import numpy as np
import pytest

from api.core.imports import ImportRequest, plan_import
from daq.csv_to_store import CsvImportError, import_csv
from daq.procedures.params import ParameterError
from daq.run_data import load_run_data
from daq.session import RigSource
from daq.store import Store, export_run_csv
from tests.store.helpers import HUNG_WEIGHT_TOW, benbam_tow_run

RELEASE_T_MONO = 101.05  # between samples 10 and 11 of ``_samples``


def _tow_positions(n: int, direction: float = 1.0) -> np.ndarray:
    """At rest for 1 s, then accelerating the ``direction`` way (10 Hz)."""
    t = np.arange(n) * 0.1
    return direction * 0.05 * np.clip(t - 1.05, 0.0, None) ** 2


def _recorded_weight_tow(store: Store) -> str:
    """A weight-driven tow as the rig records it: 2.5 kg hung, a release event."""
    from daq.sample import Quality, Sample

    run_id = benbam_tow_run(store, ["tow_position"], {**HUNG_WEIGHT_TOW})
    x = _tow_positions(60)
    store.add_samples(run_id, [
        Sample(k, 100.0 + 0.1 * k, 1.7e9 + 0.1 * k, {"tow_position": float(x[k])}, Quality.OK)
        for k in range(60)
    ])  # fmt: skip
    data = {"action": "release", "t_mono": RELEASE_T_MONO, "t_half_width": 0.002, "seq": 10}
    store.add_event(run_id, "operator", "tow_release set: brake released", data)
    store.finish_run(run_id, "completed")
    return run_id


def _export(store: Store, run_id: str, path) -> None:
    text = io.StringIO()
    export_run_csv(store, run_id, text)
    path.write_text(text.getvalue())


def test_an_export_imports_back_from_its_own_header(store: Store, tmp_path) -> None:
    """The hung mass, the drive, the release and the vehicle come back without restating
    them (the hung mass was lost and a re-imported weight-driven run was high in inertia)."""
    original = _recorded_weight_tow(store)
    _export(store, original, tmp_path / "out.csv")
    for request in (ImportRequest(), ImportRequest(force_n=24.5), ImportRequest(kind="tow")):
        plan = plan_import(tmp_path / "out.csv", request)
        assert plan.kind == "tow"
        assert plan.options["parameters"] == {"force_n": 24.5, "hung_mass_kg": 2.5}
        assert plan.options["vehicle"] == "BENBAM"
        assert plan.options["release_time_s"] == pytest.approx(1.05, abs=1e-6)
        assert set(plan.from_header) >= {"force_n", "hung_mass_kg", "release_time_s", "vehicle"}
    again = import_csv(store, tmp_path / "out.csv", kind=plan.kind, **plan.options)
    before, after = load_run_data(store, original), load_run_data(store, again)
    assert (after.drive, after.hung_mass_kg) == (before.drive, before.hung_mass_kg)
    assert after.t_release - after.t[0] == pytest.approx(before.t_release - before.t[0], abs=1e-5)
    assert store.get_run(again).vehicle == "BENBAM"


@pytest.mark.parametrize(
    ("request_", "message"),
    [
        (ImportRequest(kind="spin"), "kind: 'spin' disagrees with the file's header (tow run"),
        (ImportRequest(force_n=20.0), "force_n: 20.0 disagrees with the file's header"),
        (ImportRequest(weight_kg=3.0), "weight_kg: 3.0 disagrees with the file's header"),
        (ImportRequest(torque_nm=0.5), "torque_nm: 0.5 is not allowed (not used by a tow)"),
    ],
)
def test_what_disagrees_with_the_export_header_is_refused(store, tmp_path, request_, message):
    _export(store, _recorded_weight_tow(store), tmp_path / "out.csv")
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        plan_import(tmp_path / "out.csv", request_)


def test_a_csv_without_a_header_needs_its_kind_and_load(tmp_path) -> None:
    (tmp_path / "run.csv").write_text("t,position\n0,0\n0.1,0.01\n")
    with pytest.raises(ParameterError, match=r"kind: missing is not allowed \(allowed tow"):
        plan_import(tmp_path / "run.csv", ImportRequest(force_n=1.0))
    with pytest.raises(ParameterError, match=r"force_n: missing is not allowed .a tow needs"):
        plan_import(tmp_path / "run.csv", ImportRequest(kind="tow"))


def test_the_rig_files_limits_bound_the_load(tmp_path) -> None:
    (tmp_path / "run.csv").write_text("t,position\n0,0\n0.1,0.01\n")
    rig = RigSource.load()  # BENBAM: max_force_n = 100, max_torque_nm
    with pytest.raises(ParameterError) as caught:
        plan_import(tmp_path / "run.csv", ImportRequest(kind="tow", force_n=-1e6), rig=rig)
    assert str(caught.value) == (
        "force_n: -1000000.0 is not allowed (allowed 0 < |force_n| ≤ 100 N, rig limit "
        "max_force_n; negative for a reverse run)"
    )
    heavy = ImportRequest(kind="tow", force_n=10.0, weight_kg=50.0)
    with pytest.raises(ParameterError, match=r"weight_kg: 50.0 is not allowed \(allowed 0 < "):
        plan_import(tmp_path / "run.csv", heavy, rig=rig)
    spin = ImportRequest(kind="spin", torque_nm=99.0)
    with pytest.raises(ParameterError, match=r"torque_nm: 99.0 .*rig limit max_torque_nm"):
        plan_import(tmp_path / "run.csv", spin, rig=rig)
    plan = plan_import(tmp_path / "run.csv", ImportRequest(kind="tow", force_n=-1e6))
    assert plan.options["parameters"] == {"force_n": -1e6}  # no rig file: no limit to check


def _tow_csv(path, direction: float = 1.0, logged: float | None = None) -> None:
    x = _tow_positions(60, direction)
    lines = ["t,position" + (",pull" if logged is not None else "")]
    for k, value in enumerate(x):
        lines.append(f"{k / 10:.1f},{value:.6f}" + (f",{logged}" if logged is not None else ""))
    path.write_text("\n".join(lines) + "\n")


def test_a_load_against_the_motion_is_refused_and_nothing_is_written(store, tmp_path) -> None:
    _tow_csv(tmp_path / "forward.csv")
    with pytest.raises(ValueError, match=r"force_n: -24.5 is not allowed: the record first "
                                         r"moves the positive way .* give 24.5 N"):  # fmt: skip
        import_csv(store, tmp_path / "forward.csv", kind="tow", parameters={"force_n": -24.5})
    assert store.list_runs() == []
    import_csv(store, tmp_path / "forward.csv", kind="tow", parameters={"force_n": 24.5})
    _tow_csv(tmp_path / "reverse.csv", direction=-1.0)  # a reverse tow: both negative
    import_csv(store, tmp_path / "reverse.csv", kind="tow", parameters={"force_n": -24.5})
    still = "t,position\n" + "".join(f"{k / 10},{0.0}\n" for k in range(20))
    (tmp_path / "still.csv").write_text(still)  # no motion: nothing to check against
    import_csv(store, tmp_path / "still.csv", kind="tow", parameters={"force_n": -1.0})


def test_a_logged_drive_over_the_rig_limit_is_refused(store, tmp_path) -> None:
    _tow_csv(tmp_path / "logged.csv", logged=250.0)
    plan = plan_import(
        tmp_path / "logged.csv",
        ImportRequest(kind="tow", drive_column="pull"),
        rig=RigSource.load(),
    )
    with pytest.raises(
        ValueError, match=r"drive_column: 'pull' reaches 250 N .* max_force_n = 100"
    ):
        import_csv(store, tmp_path / "logged.csv", kind=plan.kind, **plan.options)
    assert store.list_runs() == []


def test_a_one_row_file_is_refused(store, tmp_path) -> None:
    (tmp_path / "one.csv").write_text("t,position\n0,0\n")
    with pytest.raises(CsvImportError, match="line 1: a header but 1 data row; a run needs at "):
        import_csv(store, tmp_path / "one.csv", kind="tow", parameters={"force_n": 1.0})


def test_a_release_at_or_before_the_first_sample_is_taken(store, tmp_path) -> None:
    """A record that starts at the release, or after it (ten Cate's sphere: released at
    t = 0, first sample 0.084 s later), keeps the release it was given."""
    x = 0.03 * (np.arange(30) * 0.1 + 0.1)  # moving from its first sample on
    text = "t,position\n" + "".join(f"{0.1 + k / 10:.1f},{v:.5f}\n" for k, v in enumerate(x))
    (tmp_path / "moving.csv").write_text(text)
    for given, stored in ((0.1, 0.0), (0.0, -0.1)):
        run = import_csv(store, tmp_path / "moving.csv", kind="tow",
                         parameters={"force_n": 1.0}, release_time_s=given)  # fmt: skip
        assert store.get_run(run).parameters["release_time_s"] == pytest.approx(stored)
        data = load_run_data(store, run)
        assert data.t_release - data.t[0] == pytest.approx(stored)
    early = r"release_time_s: -5.0 is not allowed; use a time within \[-2.8, 3\] s \(before the"
    with pytest.raises(ValueError, match=early):
        import_csv(store, tmp_path / "moving.csv", kind="tow", parameters={"force_n": 1.0},
                   release_time_s=-5.0)  # fmt: skip
