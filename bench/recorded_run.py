"""The run a pipeline benchmark records into: a run in the store for the PLC's channels,
and the RunRecorder that writes it (bench/clock_lateness.py, bench/poll_rate.py)."""

from __future__ import annotations

from typing import Any

from daq.plc import PlcClient
from daq.store import RunRecorder, Store


def bench_run(
    store: Store, plc: PlcClient, kind: str, parameters: dict[str, Any]
) -> tuple[str, RunRecorder]:
    """A new ``kind`` run of ``plc``'s rig and channels, and its recorder (0.5 s flushes)."""
    run_id = store.create_run(
        kind=kind,
        parameters=parameters,
        channel_names=plc.channel_names,
        rig_name=plc.rig.rig.name,
        vehicle=plc.rig.vehicle.name,
        rig_toml="",
    )
    return run_id, RunRecorder(store, run_id, flush_interval_s=0.5)
