"""Raw recordings made elsewhere: the free-motion window, glitches and the time unit are
found from the data (estimation.data.window), built by the independent test-side integrator."""

from __future__ import annotations

import numpy as np
import pytest

from estimation import estimate
from estimation.data.csv_import import run_from_csv
from estimation.data.window import find_spikes, find_window
from tests.estimation.synth import YAW_TRUTH, Physics, tow_set

HOLD_S = 0.5
SCALES = {  # inertia, K_L, K_Q: BENBAM's, and its damping scaled by area ∝ M^(2/3)
    "10 kg": (10.0, 20.16 * 0.17, 241.14 * 0.17),
    "143 kg": (143.26, 20.16, 241.14),
    "1000 kg": (1000.0, 20.16 * 3.66, 241.14 * 3.66),
}


def raw_recording(run, rng: np.random.Generator, *, spikes: int = 2) -> tuple[np.ndarray, ...]:
    """What a lab's logger writes: the run's 1 s at-rest baseline and encoder offset, then
    0.5 s of brake hold, 3 % of samples dropped, single-sample encoder glitches."""
    t, x = np.asarray(run.t), np.asarray(run.position)
    step = float(np.median(np.diff(t)))
    hold_t = t[-1] + step * np.arange(1, round(HOLD_S / step) + 1)
    t = np.concatenate([t, hold_t])
    x = np.concatenate([x, np.full(hold_t.size, x[-1])])
    keep = rng.random(t.size) >= 0.03
    keep[[0, -1]] = True
    t, x = t[keep], x[keep].copy()
    moving = np.nonzero((t > run.t_release + 0.5) & (t < t[-1] - HOLD_S - 0.5))[0]
    for i in rng.choice(moving, spikes, replace=False):
        x[i] += rng.choice([-1.0, 1.0]) * rng.uniform(0.02, 0.3)
    return t, x


def write_csv(path, t, x, **columns) -> None:
    names = ["t", "position", *columns]
    rows = zip(t, x, *columns.values(), strict=True)
    path.write_text(
        ",".join(names) + "\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in rows)
    )


@pytest.mark.parametrize("scale", SCALES)
def test_raw_recordings_estimate_within_3_percent(tmp_path, scale):
    truth = Physics(*SCALES[scale])
    rng = np.random.default_rng(7)
    runs = []
    for run in tow_set(truth, seed=3, quantum=1e-3, baseline_s=1.0):
        t, x = raw_recording(run, rng)
        path = tmp_path / f"{run.run_id}.csv"
        write_csv(path, t, x)
        runs.append(
            run_from_csv(
                path,
                axis="surge",
                drive=float(run.drive),
                hung_mass_kg=run.hung_mass_kg,
                drive_inertia=run.drive_inertia,
            )
        )
    for run in runs:
        w = run.window_found
        assert w.release_source == "motion onset" and w.end_source == "carriage at rest"
        assert w.spikes_dropped == 2
        assert w.dropped_before >= 8 and w.dropped_after >= 4
    result = estimate(runs, n_bootstrap=0)
    for run in runs:  # the truth releases at 1 s; within the time it takes to move 2 mm
        accel = float(run.drive) / (SCALES[scale][0] + run.declared_extra_inertia())
        slack = max(0.05, np.sqrt(2 * 2e-3 / accel))
        assert result.section.windows[run.run_id].t_release == pytest.approx(1.0, abs=slack)
    for name, value in zip(
        ("inertia", "linear_damping", "quadratic_damping"), SCALES[scale], strict=True
    ):
        got = result.coefficients[name].value
        assert got == pytest.approx(value, rel=0.03), (name, got, value)
    assert [e.name for e in result.effects] == []
    doc = result.to_json()["windows"][runs[0].run_id]
    assert doc["release_source"] == "motion onset, refined by the fit"
    assert doc["end_source"] == "carriage at rest" and doc["spikes_dropped"] == 2


def test_naive_window_is_what_breaks_the_fit(tmp_path):
    """The same recordings with the release at the first sample and no end (the old
    import) are far off: the window finding is what makes them estimable."""
    rng = np.random.default_rng(7)
    runs = []
    for run in tow_set(seed=3, quantum=1e-3, baseline_s=1.0):
        t, x = raw_recording(run, rng, spikes=0)
        path = tmp_path / f"{run.run_id}.csv"
        write_csv(path, t, x)
        kw = dict(drive=float(run.drive), hung_mass_kg=run.hung_mass_kg)
        runs.append(run_from_csv(path, axis="surge", t_release=float(t[0]), t_end=None, **kw))
    result = estimate(runs, n_bootstrap=0, search_effects=False)
    assert abs(result.coefficients["inertia"].value / 143.26 - 1) > 0.03


def test_release_coil_and_end_switch_columns_are_honoured(tmp_path):
    run = tow_set(seed=1, quantum=1e-3, baseline_s=1.0)[1]
    t, x = raw_recording(run, np.random.default_rng(2), spikes=0)
    coil = ((t > run.t_release) & (t <= t[-1] - HOLD_S)).astype(float)
    switch = (t > t[-1] - HOLD_S).astype(float)
    path = tmp_path / "coil.csv"
    write_csv(path, t, x, tow_release=coil, end_of_travel=switch)
    got = run_from_csv(path, axis="surge", drive=float(run.drive), hung_mass_kg=run.hung_mass_kg)
    w = got.window_found
    assert w.release_source == "release coil" and w.end_source == "end_of_travel switch"
    before = t[t <= run.t_release][-1]
    assert before <= w.t_release <= t[t > run.t_release][0]
    assert w.t_end == t[t <= t[-1] - HOLD_S][-1]


def test_given_release_and_end_are_kept():
    run = tow_set(seed=1, quantum=1e-3)[0]
    keep, report, std = find_window(run.t, run.position, t_release=0.8, t_end=5.0)
    assert (report.t_release, report.t_end, report.release_source, std) == (0.8, 5.0, "given", None)
    assert keep.all()


def test_spikes_are_found_but_kinks_and_turning_points_are_not():
    t = np.arange(0, 10, 0.1)
    x = np.where(t > 2, 0.5 * 0.2 * (t - 2) ** 2, 0.0)  # release kink at 2 s
    x = np.where(t > 8, x[t <= 8][-1], x)  # sudden stop (brake) at 8 s
    wave = 0.3 * np.sin(2 * np.pi * 0.4 * t)  # turning points every 1.25 s
    assert not find_spikes(t, x).any() and not find_spikes(t, wave).any()
    glitched = x.copy()
    glitched[[30, 55, 57, 85]] += [0.05, -0.2, 0.01, 0.3]
    assert np.nonzero(find_spikes(t, glitched))[0].tolist() == [30, 55, 57, 85]


def test_time_in_milliseconds_is_refused_with_the_fix(tmp_path):
    run = tow_set(seed=1, quantum=1e-3)[0]
    path = tmp_path / "ms.csv"
    write_csv(path, np.round(run.t, 1) * 1000.0, run.position)
    with pytest.raises(
        ValueError, match=r"column 't': median step 100(\.0)? .*looks like ms.*--time-unit ms"
    ):
        run_from_csv(path, axis="surge", drive=float(run.drive))
    same = run_from_csv(path, axis="surge", drive=float(run.drive), time_unit="ms")
    assert np.median(np.diff(same.t)) == pytest.approx(0.1, rel=0.05)


def test_spin_recordings_with_the_release_coil_estimate_within_3_percent(tmp_path):
    truth = Physics(*YAW_TRUTH)
    rng = np.random.default_rng(5)
    runs = []
    for run in tow_set(truth, axis="yaw", seed=4, quantum=1e-3, baseline_s=1.0):
        t, x = raw_recording(run, rng, spikes=1)
        coil = ((t > run.t_release) & (t <= t[-1] - HOLD_S)).astype(float)
        path = tmp_path / f"{run.run_id}.csv"
        write_csv(path, t, x, spin_release=coil)
        kw = dict(hung_mass_kg=run.hung_mass_kg, drum_radius_m=run.drum_radius_m)
        runs.append(
            run_from_csv(
                path, axis="yaw", drive=float(run.drive), drive_inertia=run.drive_inertia, **kw
            )
        )
    result = estimate(runs, n_bootstrap=0)
    for run in runs:
        w = result.section.windows[run.run_id]
        assert w.release_source == "release coil, refined by the fit"
        assert w.end_source == "release coil off" and w.spikes_dropped == 1
        assert w.t_release == pytest.approx(1.0, abs=0.02)
    for name, value in zip(
        ("inertia", "linear_damping", "quadratic_damping"), YAW_TRUTH, strict=True
    ):
        assert result.coefficients[name].value == pytest.approx(value, rel=0.03), name
    assert [e.name for e in result.effects] == []
