"""``rig estimate`` timed as users run it: a fresh process on stored runs, beside ``rig show``.

bench/estimation_speed.py times the estimator in process on synthetic records; this times
the command: interpreter start, imports, loading the runs, the search and the report, on
three kinds of record, each in the same temporary database and the same run of this script:

* ``tows``: four tows recorded on the simulated rig in process, on simulated time
  (``tests.support.simrig``; 24.5–83.3 N, as an operator would run them),
* ``kvlcc2``: the published KVLCC2 roll decay 21337 (``../shared/data/real/kvlcc2-roll-decay``,
  ``rig import --kind decay --dof roll``, its README's C44 and I44),
* ``ship2d``: the 2D section in waves (``../shared/data/real/ship2d-regular-waves``, its
  README's ``rig import --kind tow --drive-column force_sway_N``).

Each estimate runs **cold** (a fresh numba cache, ``NUMBA_CACHE_DIR`` in a temporary folder:
the first estimate after an install, kernels compiled), **after warm-up** (a fresh cache
that ``rig warm-up`` filled first, as ``rig serve`` does at its start) and **warm** (median
of ``--runs``, on the cache the cold run filled); ``rig show`` of one of the runs,
``rig runs``, ``rig --help`` and ``python -c pass`` run beside them. CPU time (user +
system of the child) is the figure to trust on a loaded machine. Prints one JSON document;
``ratios`` divides each estimate's CPU by ``rig show``'s. Targets: tows ≤ 3× show warm and
≤ 6× cold; kvlcc2 ≤ 3×; ship2d ≤ 6×; ``rig runs`` and ``rig --help`` ≤ 0.3 s CPU above
``python -c pass``.
Run: .venv/bin/python bench/estimate_process.py [--runs 3] [--src OTHER_CHECKOUT]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli_startup import RIG, bench_env, compiled_source  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "real"
#: kvlcc2-roll-decay/README.md: C44 = Δ·g·GM [N·m/rad], I44 = Δ·KXX² [kg·m²].
KVLCC2 = ("kvlcc2-roll-decay/kvlcc2_roll_decay_21337.csv", "--kind", "decay", "--dof",
          "roll", "--stiffness", "821.96", "--known-inertia", "115.74281",
          "--release-time", "2.0")  # fmt: skip
SHIP2D = ("ship2d-regular-waves/ship2d_3111_2_20Hz.csv", "--kind", "tow",
          "--drive-column", "force_sway_N", "--drive-unit", "N")  # fmt: skip
TOW_FORCES_N = (24.5, 44.1, 63.7, 83.3)
TARGETS = {"tows_warm": 3.0, "tows_cold": 6.0, "kvlcc2_warm": 3.0, "ship2d_warm": 6.0}
OVER_PYTHON_TARGET_S = 0.3


def run_timed(argv: list[str], env: dict[str, str], cwd: str) -> tuple[float, float, str]:
    """Wall and CPU time (user + system) of one fresh process, and its stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{argv[3:]} failed ({proc.returncode}): {proc.stderr.strip()}")
    return wall, after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime, proc.stdout


def medians(argv: list[str], env: dict[str, str], cwd: str, runs: int) -> dict[str, float]:
    """Median wall and CPU seconds of ``runs`` fresh processes."""
    times = [run_timed(argv, env, cwd)[:2] for _ in range(runs)]
    return {
        "wall_s": round(statistics.median(t[0] for t in times), 3),
        "cpu_s": round(statistics.median(t[1] for t in times), 3),
    }


def record_tows(db_url: str) -> list[str]:
    """Four tows on the simulated rig in process, on simulated time; their run ids."""
    from daq.session import RigSource
    from daq.sim.simtime import SimClock
    from daq.store import Store
    from tests.support.motion_runs import completed_runs
    from tests.support.simrig import rig_session

    async def record() -> list[str]:
        store = Store(db_url)
        try:
            async with rig_session(RigSource.load(), store) as session:
                return await completed_runs(session, "tow", TOW_FORCES_N)
        finally:
            store.close()

    return SimClock.run(record())


def imported(args: tuple[str, ...], env: dict[str, str], cwd: str) -> str:
    """The run id ``rig import`` printed for a published record."""
    _, _, out = run_timed([*RIG, "import", str(DATA / args[0]), *args[1:]], env, cwd)
    return out.split()[-1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="Warm runs per command (median).")
    parser.add_argument(
        "--src", type=Path, help="Time another checkout's code (e.g. main, before a change)."
    )
    parser.add_argument(
        "--only", nargs="*", choices=("tows", "kvlcc2", "ship2d"), help="Only these cases."
    )
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src = compiled_source(opts.src.resolve() if opts.src else None, tmp)
        db_url = f"sqlite:///{tmp}/rig.db"
        env = bench_env(dict(os.environ)) | {
            "RIG_DATABASE_URL": db_url,
            "XDG_DATA_HOME": tmp,
            "RIG_API_TOKEN": "bench",
            "PYTHONPATH": str(src),
        }
        subprocess.run([*RIG, "runs"], env=env, cwd=tmp, capture_output=True, check=True)
        cases = {"tows": record_tows(db_url)}
        cases["kvlcc2"] = [imported(KVLCC2, env, tmp)]
        cases["ship2d"] = [imported(SHIP2D, env, tmp)]
        cases = {k: v for k, v in cases.items() if not opts.only or k in opts.only}
        out: dict = {"source": str(opts.src or ROOT), "runs": opts.runs}
        base = medians([sys.executable, "-c", "pass"], env, tmp, opts.runs)
        out["python_c_pass"] = base
        out["commands"] = {}
        for label, args in {"rig --help": ["--help"], "rig runs": ["runs"]}.items():
            m = medians([*RIG, *args], env, tmp, opts.runs)
            m["cpu_over_python_s"] = round(m["cpu_s"] - base["cpu_s"], 3)
            m["met"] = m["cpu_over_python_s"] <= OVER_PYTHON_TARGET_S
            out["commands"][label] = m
        shown = cases.get("tows") or next(iter(cases.values()))
        show = medians([*RIG, "show", shown[0]], env, tmp, opts.runs)
        out["commands"]["rig show"] = show
        out["estimate"], out["ratios"] = {}, {}
        for name, ids in cases.items():
            argv = [*RIG, "estimate", *ids]
            row: dict = {"run_ids": [i[:8] for i in ids]}
            cold = env | {"NUMBA_CACHE_DIR": f"{tmp}/numba-{name}"}  # kept for the warm runs
            wall, cpu, _ = run_timed(argv, cold, tmp)
            row["cold"] = {"wall_s": round(wall, 3), "cpu_s": round(cpu, 3)}
            with tempfile.TemporaryDirectory() as cache:
                fresh = env | {"NUMBA_CACHE_DIR": cache}
                try:
                    row["warm_up"] = medians([*RIG, "warm-up"], fresh, tmp, 1)
                except RuntimeError as err:  # a checkout without it (--src)
                    row["warm_up"] = str(err)
                wall, cpu, _ = run_timed(argv, fresh, tmp)
                row["after_warm_up"] = {"wall_s": round(wall, 3), "cpu_s": round(cpu, 3)}
            row["warm"] = medians(argv, cold, tmp, opts.runs)
            out["estimate"][name] = row
            for how in ("cold", "after_warm_up", "warm"):
                out["ratios"][f"{name}_{how}"] = round(row[how]["cpu_s"] / show["cpu_s"], 2)
        out["targets"] = {
            k: {"ratio": out["ratios"][k], "at_most": v, "met": out["ratios"][k] <= v}
            for k, v in TARGETS.items()
            if k in out["ratios"]
        }
        out["cpu_load_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
