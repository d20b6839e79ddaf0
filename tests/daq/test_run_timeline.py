"""Host instants (release, thruster steps) mapped onto the PLC's clock of a stored run."""

from __future__ import annotations

import numpy as np

from daq.config import DEFAULT_RIG_FILE
from daq.run_data import load_run_data
from daq.sample import Quality, Sample
from daq.store import Store

#: Host monotonic time − PLC clock, s (the same instant on both clocks).
HOST_MINUS_PLC = 1000.0


def test_the_release_maps_through_the_least_delayed_samples(tmp_path):
    """Host stamps come after each reply, late by a latency that is never negative (here
    0.5 ms plus an exponential 4 ms tail, as under CPU load): the release must land on the
    PLC clock where it happened, not early by the typical latency."""
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    run_id = store.create_run(
        kind="tow",
        parameters={"force_n": 24.5, "hung_mass_kg": 2.5},
        channel_names=["tow_position", "plc_clock"],
        rig_name="BENBAM",
        vehicle="BENBAM-1",
        rig_toml=DEFAULT_RIG_FILE.read_text(),
    )
    rng = np.random.default_rng(7)
    plc = 5.0 + 0.1 * np.arange(60)
    latency = 0.0005 + rng.exponential(0.004, plc.size)
    host = plc + HOST_MINUS_PLC + latency
    release = 6.03  # on the PLC clock
    store.add_samples(
        run_id,
        [
            Sample(
                seq=k,
                t_mono=float(host[k]),
                t_wall=1.7e9 + k * 0.1,
                channels={"tow_position": max(0.0, p - release) ** 2, "plc_clock": float(p)},
                quality=Quality.OK,
            )
            for k, p in enumerate(plc)
        ],
    )
    store.add_event(
        run_id,
        "operator",
        "tow_release set",
        {"action": "release", "t_mono": release + HOST_MINUS_PLC, "t_half_width": 0.0},
    )
    data = load_run_data(store, run_id)
    assert abs(data.t_release - release) < 0.0015
    # The median offset this replaced would have put it early by the typical latency.
    median_mapped = release + HOST_MINUS_PLC + float(np.median(plc - host))
    assert release - median_mapped > 0.002
    store.close()
