"""The loader leaves out every sample whose value or time cannot be trusted, says what and
where, and refuses a run whose holes leave too little (daq.fit_exclusions)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from daq.config import DEFAULT_RIG_FILE
from daq.fit_exclusions import TooMuchLeftOut
from daq.run_data import load_run_data
from daq.sample import Quality, Sample
from daq.store import Store

RELEASE_S = 1.0  # from the first sample
PERIOD_S = 0.1


def _tow(
    tmp_path, bad: dict[int, tuple[Quality, bool]], *, missing=(), plc_clock=False, n=80
) -> tuple[Store, str]:
    """A stored tow of ``n`` samples, released at 1 s; ``bad`` maps seq → (quality, position
    NaN); ``missing`` seqs are slots the clock skipped."""
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    names = ["tow_position", "plc_clock"] if plc_clock else ["tow_position"]
    run_id = store.create_run(
        kind="tow",
        parameters={"force_n": 24.5, "hung_mass_kg": 2.5},
        channel_names=names,
        rig_name="BENBAM",
        vehicle="BENBAM-1",
        rig_toml=DEFAULT_RIG_FILE.read_text(),
    )
    samples = []
    for k in range(n):
        if k in missing:
            continue
        t = k * PERIOD_S
        quality, nan = bad.get(k, (Quality.OK, False))
        x = math.nan if nan else 0.1 * max(0.0, t - RELEASE_S) ** 2
        channels = {"tow_position": x} | ({"plc_clock": 5.0 + t} if plc_clock else {})
        samples.append(Sample(k, 100.0 + t, 1.7e9 + t, channels, quality))
    store.add_samples(run_id, samples)
    store.add_event(
        run_id, "operator", "released", {"action": "release", "t_mono": 100.0 + RELEASE_S}
    )
    return store, run_id


@pytest.mark.parametrize(
    ("bad", "missing", "reason", "count"),
    [
        ({30: (Quality.ERROR, True)}, (), "PLC read failed", 1),
        ({30: (Quality.STALE, False)}, (), "stale channel", 1),
        ({30: (Quality.OVERRUN, False)}, (29,), "slot missed, late slot, no device clock", 2),
        ({30: (Quality.OK, True)}, (), "NaN value", 1),
    ],
)
def test_each_untrusted_sample_is_left_out_and_said(tmp_path, bad, missing, reason, count):
    store, run_id = _tow(tmp_path, bad, missing=missing)
    data = load_run_data(store, run_id)
    (out,) = data.window_report().left_out
    assert (out.reason, out.count, out.in_motion) == (reason, count, True)
    assert out.end_s == pytest.approx(3.0)  # from the first sample
    assert not np.any(np.isclose(data.t - data.t[0], 3.0))  # no residual row there
    assert data.t.size == 80 - count
    assert data.window_report().to_json()["left_out"][0]["reason"] == reason
    store.close()


def test_a_late_slot_is_kept_when_the_plcs_clock_stamps_it(tmp_path):
    store, run_id = _tow(tmp_path, {30: (Quality.OVERRUN, False)}, missing=(29,), plc_clock=True)
    (out,) = load_run_data(store, run_id).window_report().left_out
    assert (out.reason, out.count) == ("slot missed", 1)  # only the slot that never came
    store.close()


def test_losses_in_the_baseline_do_not_count_as_in_the_motion(tmp_path):
    store, run_id = _tow(tmp_path, {3: (Quality.ERROR, True)})
    (out,) = load_run_data(store, run_id).window_report().left_out
    assert not out.in_motion
    store.close()


def test_a_hole_beyond_a_tows_tolerance_refuses_the_run_naming_it(tmp_path):
    store, run_id = _tow(tmp_path, {k: (Quality.ERROR, True) for k in range(30, 36)})
    with pytest.raises(TooMuchLeftOut) as err:
        load_run_data(store, run_id)
    assert str(err.value) == (
        f"run {run_id}: 6 samples left out at 3.0–3.5 s (PLC read failed): a 0.7 s hole in "
        "its free motion, longer than a tow tolerates (0.5 s); repeat the run"
    )
    store.close()


def test_too_many_scattered_losses_refuse_the_run(tmp_path):
    store, run_id = _tow(tmp_path, {k: (Quality.STALE, False) for k in range(12, 80, 3)})
    with pytest.raises(TooMuchLeftOut, match=r"of its \d+ samples in free motion left out "):
        load_run_data(store, run_id)
    store.close()
