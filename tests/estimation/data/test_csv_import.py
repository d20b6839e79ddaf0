"""CSV import: runs written to CSV and read back estimate like the originals."""

import numpy as np
import pytest

from estimation import estimate
from estimation.data.csv_import import run_from_csv
from tests.estimation.synth import tow_set


def _write(path, run, with_drive=True):
    cols = [run.t, run.position] + ([run.drive_at_samples()] if with_drive else [])
    header = "t,position" + (",drive" if with_drive else "")
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=header, comments="", fmt="%.9g")


def test_csv_round_trip_gives_the_same_estimate(tmp_path):
    runs = tow_set(seed=51)
    loaded = []
    for i, r in enumerate(runs):
        path = tmp_path / f"{r.run_id}.csv"
        _write(path, r, with_drive=i % 2 == 0)
        drive = None if i % 2 == 0 else float(r.drive)
        loaded.append(
            run_from_csv(
                path,
                axis="surge",
                drive=drive,
                hung_mass_kg=r.hung_mass_kg,
                drive_inertia=r.drive_inertia,
                t_release=r.t_release,
            )
        )
    assert all(np.ndim(r.drive) == 0 for r in loaded)  # constant columns become scalars
    a = estimate(runs, n_bootstrap=0).to_json()["coefficients"]
    b = estimate(loaded, n_bootstrap=0).to_json()["coefficients"]
    for k in a:
        assert b[k]["value"] == pytest.approx(a[k]["value"], rel=1e-6)


def test_csv_errors_name_the_column(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("time,x\n0,0\n")
    with pytest.raises(ValueError, match=r"bad.csv: columns: got \['time', 'x'\], missing"):
        run_from_csv(path, axis="surge", drive=4.9)
    path.write_text("t,position\n0,zero\n")
    with pytest.raises(ValueError, match="not a number"):
        run_from_csv(path, axis="surge", drive=4.9)
