"""Cost of the simulated rig: plant integration speed and Modbus request round trips.

* ``plant``: 1 ms steps integrated per second of CPU while a tow, a spin and both
  thrusters are active (the worst case; at rest the plant skips idle steps), and the
  resulting real-time factor (target: >= 20x, so the simulator never falls behind).
* ``modbus_tcp``: round-trip time of one read of the 10 BENBAM input registers from a
  pymodbus client to the simulator running in its own thread (``SimulatedRigThread``).

Prints one JSON document.  Usage: ``.venv/bin/python bench/sim_plant.py [--reads 2000]``
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pymodbus.client import ModbusTcpClient

from daq.config import load_rig
from daq.sim.plant import STEP_S, Plant
from daq.sim.plant_channels import write_channel
from daq.sim.simulated_rig import SimulatedRigThread


def plant_speed(seconds: float) -> dict:
    rig = load_rig()
    plant = Plant(rig)
    plant.advance(0.0)
    write_channel(plant, "sim_tow_weight", 0.5)
    write_channel(plant, "sim_spin_weight", 0.5)
    write_channel(plant, "tow_release", 1)
    write_channel(plant, "spin_release", 1)
    plant.set_commands([0.3, 0.2])
    t0 = time.process_time()
    plant.advance(seconds)
    cpu = time.process_time() - t0
    steps_per_s = seconds / STEP_S / cpu
    return {
        "simulated_s": seconds,
        "cpu_s": round(cpu, 4),
        "steps_per_cpu_s": round(steps_per_s),
        "real_time_factor": round(steps_per_s * STEP_S, 1),
        "target_real_time_factor": 20,
        "ok": steps_per_s * STEP_S >= 20,
    }


def modbus_round_trip(reads: int) -> dict:
    rig = load_rig()
    with SimulatedRigThread(rig) as sim:
        client = ModbusTcpClient("127.0.0.1", port=sim.endpoints.port, timeout=0.5, retries=0)
        client.connect()
        times = []
        try:
            for _ in range(reads):
                t0 = time.perf_counter()
                rr = client.read_input_registers(0, count=10, device_id=rig.modbus.unit_id)
                times.append(time.perf_counter() - t0)
                if rr.isError():
                    raise RuntimeError(f"read failed: {rr}")
        finally:
            client.close()
    times.sort()
    return {
        "reads": reads,
        "p50_ms": round(statistics.median(times) * 1e3, 3),
        "p99_ms": round(times[int(0.99 * (len(times) - 1))] * 1e3, 3),
        "max_ms": round(times[-1] * 1e3, 3),
        "reads_per_s": round(reads / sum(times)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--reads", type=int, default=2000, help="Modbus reads to time")
    args = parser.parse_args()
    result = {
        "bench": "sim_plant",
        "plant": plant_speed(args.seconds),
        "modbus_tcp": modbus_round_trip(args.reads),
    }
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
