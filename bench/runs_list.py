"""CPU time of ``rig runs`` over a database of many runs (default 10,000 tows recorded on
BENBAM's rig file, in SQLite), beside ``python -c pass`` and the same command on an empty
database: what the runs cost, and what starting the command costs.

Prints one JSON document: per command the median CPU time (user + system) of ``--repeat``
fresh processes, and in process the time of ``Store.list_runs`` for one page and for all
runs, and of ``Store.count_runs``.

    .venv/bin/python bench/runs_list.py [--runs N] [--repeat R]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from daq.store import Store
from tests.store.helpers import BENBAM_TOML, HUNG_WEIGHT_TOW

RIG = [
    sys.executable,
    "-c",
    "import sys; from api.cli.main import main; sys.argv[0] = 'rig'; main()",
]


def fill(url: str, count: int) -> None:
    """``count`` completed tows without samples, one transaction each."""
    with Store(url) as store:
        for i in range(count):
            store.import_run(
                samples=[],
                started_at=1.7e9 + 60 * i,
                stopped_at=1.7e9 + 60 * i + 30,
                kind="tow",
                parameters=HUNG_WEIGHT_TOW,
                channel_names=["tow_position", "load_cell"],
                rig_name="BENBAM tow tank",
                vehicle="BENBAM",
                rig_toml=BENBAM_TOML,
                metadata={"operator": "ana", "tags": ["bench"]},
            )


def cpu_of(argv: list[str], url: str, repeat: int) -> float:
    """Median CPU time (user + system) of ``repeat`` fresh processes of ``argv``, s."""
    env = os.environ | {"RIG_DATABASE_URL": url}
    cpus = []
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run(argv, env=env, capture_output=True, check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return round(statistics.median(cpus), 3)


def in_process(url: str, count: int) -> dict[str, float]:
    """CPU time of the store's calls behind ``rig runs``, s."""
    figures = {}
    with Store(url) as store:
        for label, call in (
            ("list_runs_page_of_50", lambda: store.list_runs(limit=50)),
            ("count_runs", store.count_runs),
            (f"list_runs_all_{count}", lambda: store.list_runs(limit=max(count, 1))),
        ):
            started = time.process_time()
            call()
            figures[label] = round(time.process_time() - started, 4)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-runs-") as folder:
        full, empty = f"sqlite:///{folder}/runs.db", f"sqlite:///{folder}/empty.db"
        fill(full, args.runs)
        Store(empty).close()
        commands = {
            "python -c pass": ([sys.executable, "-c", "pass"], full),
            "rig runs (empty database)": ([*RIG, "runs"], empty),
            "rig runs": ([*RIG, "runs"], full),
            f"rig runs --limit {args.runs}": ([*RIG, "runs", "--limit", str(args.runs)], full),
        }
        cpu = {label: cpu_of(argv, url, args.repeat) for label, (argv, url) in commands.items()}
        store_calls = in_process(full, args.runs)
    over_empty = cpu["rig runs"] - cpu["rig runs (empty database)"]
    print(
        json.dumps(
            {
                "benchmark": "runs_list",
                "runs": args.runs,
                "repeat": args.repeat,
                "cpu_s": cpu,
                "rig_runs_cpu_over_empty_s": round(over_empty, 3),
                "store_cpu_s": store_calls,
                "cpu_load_1min": round(os.getloadavg()[0], 2),
                "python": platform.python_version(),
            },
            indent=2,
        )
    )


if __name__ == "__main__":
    main()
