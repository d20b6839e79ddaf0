"""Imports of every kind round-trip into estimation: a tow driven by a varying force logged
per sample (``rig import --drive-column`` and ``POST /api/runs/import?drive_column=``),
and a pendulum free decay of a half-scale vehicle (``rig import --kind pendulum --rig``).
The data come from scipy's ``solve_ivp``, not from the rig's simulator or the estimator's
own integrator."""

from __future__ import annotations

import io
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from api.core.estimation_job import run_estimation
from daq.config import DEFAULT_RIG_FILE, load_rig
from daq.store import Store, export_run_csv
from tests.estimation import pendulum_synth
from tests.estimation.pendulum_synth import PendulumGeometry
from tests.support.cli import RigCliText

#: Surge truth (seed 000): inertia kg, linear N·s/m, quadratic N·s²/m².
TRUTH = {"inertia": 143.26, "linear_damping": 20.16, "quadratic_damping": 241.14}
KGF = 9.80665
RELEASE_S, RATE_HZ = 1.0, 10.0


def _force(t: np.ndarray | float, mean: float) -> np.ndarray:
    """The towing force, N: a slow swell about ``mean`` (a winch with a sagging motor)."""
    return mean * (1 + 0.35 * np.sin(2 * np.pi * (np.asarray(t) - RELEASE_S) / 7.0))


def _tow_csv(path: Path, mean: float, seed: int) -> None:
    """12 s at 10 Hz: held still to the release, then free under the varying force;
    position encoder-quantized (0.1 mm) with noise, force in kgf with load-cell noise."""
    m, kl, kq = TRUTH.values()

    def rhs(t, y):
        return [y[1], (_force(t, mean) - kl * y[1] - kq * abs(y[1]) * y[1]) / m]

    t = np.arange(0.0, 12.0, 1 / RATE_HZ)
    sol = solve_ivp(rhs, (RELEASE_S, t[-1]), [0.0, 0.0], rtol=1e-10, atol=1e-12, dense_output=True)
    x = np.where(t < RELEASE_S, 0.0, sol.sol(np.maximum(t, RELEASE_S))[0])
    rng = np.random.default_rng(seed)
    x = np.round((x + 5e-5 * rng.standard_normal(t.size)) / 1e-4) * 1e-4
    kgf = _force(t, mean) / KGF + 0.002 * rng.standard_normal(t.size)
    lines = ["t,position,pull (kgf)"] + [
        f"{a:.1f},{b:.4f},{c:.4f}" for a, b, c in zip(t, x, kgf, strict=True)
    ]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


@pytest.fixture
def rig(tmp_path: Path) -> RigCliText:
    return RigCliText(tmp_path)


def _coefficients(data: dict) -> dict[str, tuple[float, float]]:
    c = data["coefficients"]
    return {k: (c[k]["value"], c[k]["std"]) for k in TRUTH}


def test_a_tow_driven_by_a_logged_force_recovers_the_coefficients_and_round_trips(
    rig, tmp_path: Path
) -> None:
    ids = []
    for mean, seed in ((20.0, 1), (45.0, 2)):
        _tow_csv(tmp_path / f"tow{seed}.csv", mean, seed)
        ids.append(rig("import", f"tow{seed}.csv", "--kind", "tow", "--drive-column",
                       "pull (kgf)", "--drive-unit", "kgf", "--release-time", "1"))  # fmt: skip
    store = Store(rig.db)
    try:
        run = store.get_run(ids[0])
        assert run.parameters["drive_channel"] == "drive_force"
        assert "force_n" not in run.parameters and "drive_force" in run.channel_names
        logged = store.samples(ids[0]).channels["drive_force"]
        assert logged[10] == pytest.approx(20.0, abs=0.1)  # stored in N, not kgf
        data = run_estimation(store, ids, search_effects=False)
        got = _coefficients(data)
        for name, truth in TRUTH.items():
            value, std = got[name]
            assert abs(value - truth) < max(3 * std, 0.01 * truth), (name, value, std)

        # Export → import → the same coefficients.
        again = []
        for run_id in ids:
            buf = io.StringIO()
            export_run_csv(store, run_id, buf)
            (tmp_path / f"{run_id}.csv").write_text(buf.getvalue(), encoding="utf-8")
            again.append(rig("import", f"{run_id}.csv", "--kind", "tow", "--drive-column",
                             "drive_force", "--release-time", "1"))  # fmt: skip
        redo = _coefficients(run_estimation(store, again, search_effects=False))
        for name in TRUTH:
            assert redo[name][0] == pytest.approx(got[name][0], rel=1e-6)
            assert redo[name][1] == pytest.approx(got[name][1], rel=1e-3)
    finally:
        store.close()


def test_logged_drive_errors_are_one_line_naming_the_column(rig, tmp_path: Path) -> None:
    _tow_csv(tmp_path / "tow.csv", 20.0, 3)
    text = (tmp_path / "tow.csv").read_text(encoding="utf-8").splitlines()
    text[5] = text[5].rsplit(",", 1)[0] + ",n/a"
    (tmp_path / "bad.csv").write_text("\n".join(text) + "\n", encoding="utf-8")
    cases = [
        (["tow.csv", "--drive-column", "pull"], "--drive-column: no column 'pull' in"),
        (["bad.csv", "--drive-column", "pull (kgf)"],
         "line 6, column 'pull (kgf)': 'n/a' is not a number"),
        (["tow.csv", "--drive-column", "pull (kgf)", "--drive-unit", "stone"],
         "--drive-unit: 'stone' is not allowed; use one of N, kN, kgf, gf, lbf"),
        (["tow.csv", "--drive-column", "pull (kgf)", "--force", "3"],
         "--force: not used with --drive-column"),
    ]  # fmt: skip
    for argv, expect in cases:
        err = rig("import", *argv, "--kind", "tow", code=2)
        assert expect in err and err.count("\n") == 1, (argv, err)
    assert "no runs" in rig("runs") or rig("runs").count("\n") <= 1


#: A half-scale BENBAM on a shorter rod: masses × 1/8, inertias × 1/32, 0.25 kg heavy in
#: water; its added mass and damping scaled alike (α × 1/8). g is the rig file's.
HALF = PendulumGeometry(
    pivot_to_vehicle_m=0.6,
    rod_mass_kg=3.0,
    rod_cg_m=0.3,
    rod_inertia_kg_m2=0.36,
    vehicle_mass_kg=3.75,
    vehicle_inertia_kg_m2=1.1 / 32,
    buoyancy_kg=3.5,
    pivot_damping_nm_s=0.05,
    g=load_rig(DEFAULT_RIG_FILE).rig.g,
)
HALF_ALPHA, HALF_BETA = 14.2, 2.5


def _half_scale_rig(path: Path) -> None:
    """BENBAM's rig file with the half-scale vehicle and pendulum."""
    text = DEFAULT_RIG_FILE.read_text(encoding="utf-8")
    text = re.sub(r"(?m)^dry_mass_kg = .*$", f"dry_mass_kg = {HALF.vehicle_mass_kg}", text)
    text = re.sub(r'(?m)^name = "BENBAM"$', 'name = "BENBAM half scale"', text)
    keys = {
        "pivot_to_vehicle_m": HALF.pivot_to_vehicle_m,
        "rod_mass_kg": HALF.rod_mass_kg,
        "rod_cg_m": HALF.rod_cg_m,
        "rod_inertia_kg_m2": HALF.rod_inertia_kg_m2,
        "vehicle_inertia_kg_m2": HALF.vehicle_inertia_kg_m2,
        "buoyancy_kg": HALF.buoyancy_kg,
        "pivot_damping_nm_s": HALF.pivot_damping_nm_s,
    }
    head, pendulum = text.split("[pendulum]")
    for key, value in keys.items():
        pendulum, n = re.subn(rf"(?m)^{key} = \S+", f"{key} = {value!r}", pendulum)
        assert n == 1, key
    path.write_text(head + "[pendulum]" + pendulum, encoding="utf-8")


def test_a_half_scale_pendulum_decay_imports_and_estimates_its_coefficients(
    rig, tmp_path: Path
) -> None:
    run = pendulum_synth.decay(HALF, alpha=HALF_ALPHA, beta=HALF_BETA, amplitude=0.2,
                               duration=30.0, t_release=2.0)  # fmt: skip
    lines = ["t,position"] + [f"{a:.1f},{b:.5f}" for a, b in zip(run.t, run.angle, strict=True)]
    (tmp_path / "decay.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    _half_scale_rig(tmp_path / "half.toml")
    err = rig("import", "decay.csv", "--kind", "pendulum", code=2)
    assert "--rig: a pendulum import needs the rig file" in err
    run_id = rig("import", "decay.csv", "--kind", "pendulum", "--rig", "half.toml",
                 "--release-time", "2")  # fmt: skip
    store = Store(rig.db)
    try:
        stored = store.get_run(run_id)
        assert stored.kind == "pendulum" and stored.vehicle == "BENBAM half scale"
        assert list(stored.channel_names) == ["pendulum_angle"]
        data = run_estimation(store, [run_id], search_effects=False)
    finally:
        store.close()
    assert data["analysis"] == "pendulum"
    c = data["coefficients"]
    for name, truth in (("added_mass", HALF_ALPHA), ("linear_damping", HALF_BETA)):
        value, std = c[name]["value"], c[name]["std"]
        assert 0 < std < 0.1 * truth, (name, value, std)
        assert abs(value - truth) < 3 * std, (name, value, std)


def test_a_spin_takes_its_logged_torque_per_sample_in_si(tmp_path: Path) -> None:
    """``N*m`` reads as N·m, kgf·m is scaled to N·m, and the estimator's drive is the
    column at each sample (not a constant)."""
    from daq.csv_to_store import import_csv
    from daq.run_data import load_run_data

    t = np.arange(0.0, 6.0, 0.1)
    angle = np.where(t < 1.0, 0.0, 0.2 * (t - 1.0) ** 2)
    torque = 0.1 + 0.02 * t
    lines = ["t,position,tq"] + [
        f"{a:.1f},{b:.6f},{c:.4f}" for a, b, c in zip(t, angle, torque, strict=True)
    ]
    (tmp_path / "spin.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    with Store(f"sqlite:///{tmp_path}/rig.db") as store:
        for unit, scale in (("N*m", 1.0), ("kgf·m", KGF)):
            run_id = import_csv(store, tmp_path / "spin.csv", kind="spin", parameters={},
                                drive_column="tq", drive_unit=unit, release_time_s=1.0)  # fmt: skip
            assert store.get_run(run_id).parameters["drive_channel"] == "drive_torque"
            data = load_run_data(store, run_id)
            assert not data.is_constant_drive()
            expected = np.interp(data.t, t, torque) * scale
            assert np.allclose(data.drive, expected, rtol=1e-9, atol=1e-9)
        with pytest.raises(ValueError, match="drive_unit: 'N' is not allowed; use one of N·m"):
            import_csv(store, tmp_path / "spin.csv", kind="spin", parameters={},
                       drive_column="tq", drive_unit="N")  # fmt: skip
