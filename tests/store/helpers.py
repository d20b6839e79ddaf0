"""Helpers shared by the storage tests."""

from __future__ import annotations

import math

from daq.sample import Quality, Sample
from daq.store import Store

RIG_TOML = '[rig]\nname = "BENBAM"\nmode = "simulated"\n'


def new_run(store: Store, **overrides) -> str:
    """A running tow run with two channels (arguments can be overridden)."""
    arguments = {
        "kind": "tow",
        "parameters": {"force_n": 24.5},
        "channel_names": ["tow_position", "load_cell"],
        "rig_name": "BENBAM",
        "vehicle": "BENBAM-1",
        "rig_toml": RIG_TOML,
    }
    arguments.update(overrides)
    return store.create_run(**arguments)


def make_samples(start: int, count: int, *, t0_wall: float = 1.7e9) -> list[Sample]:
    """``count`` samples from seq ``start`` at 10 Hz with recognisable values."""
    return [
        Sample(
            seq=seq,
            t_mono=100.0 + seq * 0.1,
            t_wall=t0_wall + seq * 0.1,
            channels={"tow_position": seq * 0.01, "load_cell": math.sin(seq)},
            quality=Quality.OK,
        )
        for seq in range(start, start + count)
    ]
