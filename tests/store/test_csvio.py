"""CSV import (validated, one transaction) and CSV/JSON export of runs."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

from daq.csv_to_store import CsvImportError, import_csv
from daq.store import DuplicateSample, Store, export_run_csv, export_run_json
from tests.store.helpers import make_samples, new_run

TOW_CSV = "t,position,load_cell\n0.0,0.0,24.1\n0.1,0.004,24.3\n0.2,0.016,\n0.3,0.035,24.2\n"


def write(tmp_path, text: str, name: str = "run.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_import_makes_a_completed_run_with_mapped_channels(store: Store, tmp_path) -> None:
    path = write(tmp_path, TOW_CSV)
    run_id = import_csv(store, path, kind="tow", parameters={"force_n": 24.5, "hung_mass_kg": 2.5})
    run = store.get_run(run_id)
    assert (run.kind, run.status, run.sample_count) == ("tow", "completed", 4)
    assert run.parameters == {
        "source": "import",
        "force_n": 24.5,
        "hung_mass_kg": 2.5,
        "file": "run.csv",
    }
    assert run.channel_names == ("tow_position", "load_cell")
    assert run.duration_s == pytest.approx(0.3, abs=1e-5)
    table = store.samples(run_id)
    np.testing.assert_allclose(table.t, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(table.channels["tow_position"], [0.0, 0.004, 0.016, 0.035])
    assert math.isnan(table.channels["load_cell"][2])  # empty cell = not read

    spin = import_csv(
        store,
        write(tmp_path, "t,position\n0,0\n0.5,0.1\n", "s.csv"),
        kind="spin",
        parameters={"torque_nm": 0.907},
    )
    assert store.get_run(spin).channel_names == ("yaw_angle",)


def test_an_unread_sample_imports_as_recorded_and_a_blank_position_elsewhere_is_refused(
    store: Store, tmp_path
) -> None:
    """A towrig export writes a failed read's position empty, its quality flagging it (2:
    read error): it imports as it was recorded, NaN and flagged, for estimation to leave
    out. A blank position on a row whose quality does not say so is refused, naming it."""
    text = "t,position,quality\n0,0,0\n0.1,0.004,0\n0.2,,2\n0.3,0.035,0\n"
    run_id = import_csv(store, write(tmp_path, text), kind="tow", parameters={"force_n": 24.5})
    table = store.samples(run_id)
    assert math.isnan(table.channels["tow_position"][2]) and table.quality[2] == 2
    np.testing.assert_array_equal(table.channels["tow_position"][[0, 1, 3]], [0.0, 0.004, 0.035])
    blank = "t,position,quality\n0,0,0\n0.1,,0\n0.2,0.01,0\n"
    with pytest.raises(CsvImportError, match="line 3, column 'tow_position': '' is not a number"):
        import_csv(store, write(tmp_path, blank, "b.csv"), kind="tow", parameters={"force_n": 1.0})


def test_csv_export_reimports_identically(store: Store, tmp_path) -> None:
    run_id = new_run(store)
    store.add_samples(run_id, make_samples(0, 50))
    store.finish_run(run_id, "completed")
    store.set_run_metadata(run_id, {"operator": "Åsa", "tags": ["fins-v2"], "ballast": "B3"})
    exported = io.StringIO()
    assert export_run_csv(store, run_id, exported) == 50
    lines = exported.getvalue().splitlines()
    header = next(line for line in lines if not line.startswith("#"))
    meta_line = next(line for line in lines if line.startswith("# metadata: "))
    assert json.loads(meta_line.removeprefix("# metadata: ")) == {
        "operator": "Åsa", "tags": ["fins-v2"], "ballast": "B3"
    }  # fmt: skip
    assert header == "t,seq,t_mono,t_wall,quality,tow_position,load_cell"
    assert any(line.startswith("# units: t=s, seq=1, t_mono=s") for line in lines)

    again = import_csv(
        store, write(tmp_path, exported.getvalue(), "export.csv"), kind="tow",
        parameters={"force_n": 24.5}, metadata={"notes": "re-imported"},
    )  # fmt: skip
    copy_run, original_run = store.get_run(again), store.get_run(run_id)
    assert (copy_run.source, copy_run.source_file) == ("imported", "export.csv")
    assert original_run.source == "recorded" and original_run.imported_at is None
    recorded_at = store.samples(run_id).t_wall[0]  # the first sample's wall time, kept
    assert copy_run.started_at.timestamp() == pytest.approx(recorded_at, abs=1e-6)
    assert copy_run.imported_at is not None and copy_run.imported_at > original_run.stopped_at
    assert copy_run.metadata == original_run.metadata | {"notes": "re-imported"}
    assert [r.id for r in store.list_runs(source="imported")] == [again]
    original, copy = store.samples(run_id), store.samples(again)
    for column in ("seq", "quality"):
        np.testing.assert_array_equal(getattr(copy, column), getattr(original, column))
    for column in ("t_mono", "t_wall"):  # written to the µs
        np.testing.assert_allclose(getattr(copy, column), getattr(original, column), atol=5e-7)
    for name in ("tow_position", "load_cell"):  # no rig file: Python's shortest repr, exact
        np.testing.assert_array_equal(copy.channels[name], original.channels[name])
    second = io.StringIO()
    export_run_csv(store, again, second)
    data = [line for line in exported.getvalue().splitlines() if not line.startswith("#")]
    assert [line for line in second.getvalue().splitlines() if not line.startswith("#")] == data


def test_json_export_holds_run_samples_events_results(store: Store) -> None:
    run_id = new_run(store)
    store.add_samples(run_id, make_samples(0, 3))
    store.add_event(run_id, "limit", "end of travel")
    store.add_result([run_id], "estimation", {"k": 1.0})
    out = io.StringIO()
    export_run_json(store, run_id, out)
    document = json.loads(out.getvalue())
    assert document["run"]["id"] == run_id
    assert document["samples"]["seq"] == [0, 1, 2]
    assert document["events"][0]["message"] == "end of travel"
    assert document["results"][0]["data"] == {"k": 1.0}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty file"),
        ("0.0,0.0\n0.1,0.1\n", "line 1: no header with a 't' column"),
        ("t,load_cell\n0,1\n", "line 1: no 'position' column"),
        ("t,position\n", "a header but no data rows"),
        ("t,position\n0,0\n0.1,abc\n", "line 3, column 'tow_position': 'abc' is not a number"),
        ("t,position\n0,0\nnan,0.1\n", "line 3, column 't': 'nan' is not allowed; use a finite"),
        ("t,position\n0,0\n0.1,inf\n", "line 3, column 'tow_position': 'inf' is not allowed"),
        ("t,position\n0,0\n0.2,1\n0.2,2\n", "line 4, column 't': '0.2' is not greater than"),
        ("t,position\n0,0\n0.1\n", "line 3: 1 fields, the header has 2"),
        ("t,position,t\n0,0,0\n", "repeated column names"),
        ("t,seq,position\n0,0,0\n0.1,0,0\n", "line 3, column 'seq': '0' is not greater"),
        ("t,position,load_cell\n0,0,1\n0.1,0.1,-inf\n", "column 'load_cell': '-inf' is not"),
    ],
)
def test_a_bad_csv_is_rejected_naming_the_line_and_nothing_is_written(
    store: Store, tmp_path, text: str, message: str
) -> None:
    with pytest.raises(CsvImportError, match=message):
        import_csv(store, write(tmp_path, text), kind="tow", parameters={"force_n": 24.5})
    assert store.list_runs() == [] and store.stats()["samples"] == 0


@pytest.mark.parametrize(
    ("kind", "parameters", "message"),
    [
        ("tow", {"force_n": 0.0}, r"force_n: 0.0 is not allowed; use a finite number other "),
        ("spin", {"torque_nm": -0.5, "hung_mass_kg": -0.5}, "hung_mass_kg: -0.5 is not allowed"),
        ("tow", {"force_n": float("nan")}, "force_n: nan is not allowed"),
        ("tow", {"torque_nm": 1.0}, "force_n: missing"),
        ("spin", {"torque_nm": 0.9, "hung_mass_kg": 0}, "hung_mass_kg: 0 is not allowed"),
        ("thrust", {"force_n": 1.0}, "kind: 'thrust' is not allowed; use one of tow, spin"),
    ],
)
def test_bad_import_parameters_are_rejected(store: Store, tmp_path, kind, parameters, message):
    with pytest.raises(ValueError, match=message):
        import_csv(store, write(tmp_path, TOW_CSV), kind=kind, parameters=parameters)
    assert store.list_runs() == []


def test_a_failure_late_in_the_import_rolls_everything_back(store: Store, tmp_path) -> None:
    """A seq gap is fine; a repeated seq is refused by the database inside the transaction
    that already created the run, so the run disappears too."""
    text = "t,seq,position\n0,0,0\n0.1,2,0.1\n"
    run_id = import_csv(store, write(tmp_path, text), kind="tow", parameters={"force_n": 1.0})
    assert store.samples(run_id).seq.tolist() == [0, 2]
    with pytest.raises(DuplicateSample, match="already stored"):
        store.import_run(
            kind="tow",
            parameters={"force_n": 1.0},
            channel_names=["tow_position"],
            rig_name="r",
            vehicle="v",
            rig_toml="",
            samples=make_samples(0, 2) + make_samples(1, 1),
            started_at=0.0,
            stopped_at=1.0,
        )
    assert len(store.list_runs()) == 1


def test_an_import_over_the_row_limit_is_refused_naming_the_line(
    store: Store, tmp_path, monkeypatch
) -> None:
    monkeypatch.setattr("daq.csv_to_store.MAX_IMPORT_ROWS", 5)
    path = tmp_path / "long.csv"
    path.write_text("t,position\n" + "".join(f"{i / 10},0.0\n" for i in range(6)))
    with pytest.raises(CsvImportError, match=r"line 7: more than 5 data rows \(the import limit\)"):
        import_csv(store, path, kind="tow", parameters={"force_n": 5.0})
    assert store.list_runs() == []
    path.write_text("t,position\n" + "".join(f"{i / 10},0.0\n" for i in range(5)))
    run_id = import_csv(store, path, kind="tow", parameters={"force_n": 5.0})
    assert store.get_run(run_id).sample_count == 5


def test_a_long_import_is_written_in_batches_and_a_late_failure_ends_it_aborted(
    store: Store, tmp_path, monkeypatch
) -> None:
    monkeypatch.setattr("daq.csv_to_store.IMPORT_BATCH_ROWS", 4)
    path = tmp_path / "long.csv"
    path.write_text("t,position\n" + "".join(f"{i / 10},{i / 100}\n" for i in range(10)))
    transactions = []
    real = store.transaction

    def counted():
        transactions.append(1)
        return real()

    monkeypatch.setattr(store, "transaction", counted)
    run_id = import_csv(store, path, kind="tow", parameters={"force_n": 5.0})
    run = store.get_run(run_id)
    assert (run.status, run.sample_count) == ("completed", 10)
    assert np.allclose(store.samples(run_id).channels["tow_position"], np.arange(10) / 100)
    assert len(transactions) == 5  # the run, 3 batches of ≤ 4, the finish

    calls = []
    insert = store._store_batch

    def fail_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise OSError("disk full")
        return insert(*args, **kwargs)

    monkeypatch.setattr(store, "_store_batch", fail_second)
    with pytest.raises(OSError, match="disk full"):
        import_csv(store, path, kind="tow", parameters={"force_n": 5.0})
    failed = [r for r in store.list_runs() if r.id != run_id]
    assert [(r.status, r.reason, r.sample_count) for r in failed] == [
        ("aborted", "import failed: disk full", 4)
    ]


def test_a_reverse_run_imports_with_its_signed_drive_and_round_trips(store: Store, tmp_path):
    """A tow pulled back from the far end: the negative force is kept, the estimator's view
    has it, and the run exported and imported again is the same run."""
    from daq.run_data import load_run_data

    t = np.arange(60) * 0.1
    x = 5.4 - 0.15 * np.clip(t - 1.0, 0.0, None) ** 1.5  # released at 1 s, moving back
    text = "t,position\n" + "".join(f"{a:.1f},{b:.5f}\n" for a, b in zip(t, x, strict=True))
    run_id = import_csv(
        store,
        write(tmp_path, text),
        kind="tow",
        parameters={"force_n": -24.5, "hung_mass_kg": 2.5},
    )
    assert store.get_run(run_id).parameters["force_n"] == -24.5
    data = load_run_data(store, run_id)
    assert data.drive == -24.5 and data.hung_mass_kg == 2.5
    assert data.t_release == pytest.approx(1.0, abs=0.15)  # found from the motion, backwards
    exported = io.StringIO()
    export_run_csv(store, run_id, exported)
    again = import_csv(
        store,
        write(tmp_path, exported.getvalue(), "again.csv"),
        kind="tow",
        parameters={"force_n": -24.5, "hung_mass_kg": 2.5},
    )
    positions = [store.samples(r).channels["tow_position"] for r in (run_id, again)]
    np.testing.assert_allclose(positions[1], positions[0])
    document = io.StringIO()
    export_run_json(store, again, document)
    assert json.loads(document.getvalue())["run"]["parameters"]["force_n"] == -24.5

    spin = import_csv(
        store,
        write(tmp_path, "t,position\n0,0\n0.5,-0.1\n1.0,-0.3\n", "s.csv"),
        kind="spin",
        parameters={"torque_nm": -0.907},
    )
    assert store.get_run(spin).parameters["torque_nm"] == -0.907
