"""Child process for the SIGKILL test: records samples at 100 Hz through a RunRecorder.

Usage: python -m tests.store.record_child DATABASE_URL. Prints ``run <id>`` once, then
``put <seq>`` after every sample handed to the recorder, until killed.
"""

from __future__ import annotations

import asyncio
import math
import sys
import time

from daq.sample import Sample
from daq.store import RunRecorder, Store

RATE_HZ = 100.0


async def record(url: str) -> None:
    store = Store(url)
    run_id = store.create_run(
        kind="tow",
        parameters={"force_n": 24.5},
        channel_names=["tow_position", "load_cell"],
        rig_name="BENBAM",
        vehicle="BENBAM-1",
        rig_toml="",
    )
    print("run", run_id, flush=True)
    recorder = RunRecorder(store, run_id, flush_interval_s=0.5)
    flusher = asyncio.create_task(recorder.run())
    loop = asyncio.get_running_loop()
    start = loop.time()
    seq = 0
    while True:
        await asyncio.sleep(max(0.0, start + seq / RATE_HZ - loop.time()))  # paced at 100 Hz
        recorder.put(
            Sample(
                seq,
                time.monotonic(),
                time.time(),
                {"tow_position": seq * 1e-3, "load_cell": math.sin(seq)},
            )
        )
        print("put", seq, flush=True)
        seq += 1
    await flusher  # never reached: the test kills this process


if __name__ == "__main__":
    asyncio.run(record(sys.argv[1]))
