"""CPU time of opening a NEW database, each in a fresh process, against opening one already at
head: what making the schema costs a CLI, a service or a test on its first open.

Three commands, each timed ``--runs`` times as a fresh process (user + system CPU of the
child, the figure to trust on a loaded machine), on SQLite files in a temporary folder:

* ``open new``: ``Store(url).close()`` on a file that does not exist yet,
* ``open at head``: the same on a file already at head (the difference is the schema's cost),
* ``rig runs new``: ``rig runs`` with ``RIG_DATABASE_URL`` on a file that does not exist yet,

beside ``python -c pass``. With ``--compare OTHER_CHECKOUT`` every timed process alternates
between this checkout and OTHER (e.g. the base), so both see the same load, and ``ratios``
divides this checkout's medians by OTHER's. Prints one JSON document.

    .venv/bin/python bench/fresh_database.py [--runs 7] [--compare /work/b40]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.cli_startup import RIG, bench_env, compiled_source  # noqa: E402

OPEN = [sys.executable, "-c", "import sys; from daq.store import Store; Store(sys.argv[1]).close()"]


def cpu_of(argv: list[str], env: dict[str, str], cwd: str) -> float:
    """CPU seconds (user + system) of one fresh process of ``argv``; it must succeed."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, check=False)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise RuntimeError(f"{argv[2:]} failed ({proc.returncode}): {proc.stderr.strip()}")
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="Processes per command and source.")
    parser.add_argument("--compare", type=Path, help="Another checkout, timed alternately.")
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        sources = {"this": compiled_source(None, tmp)}
        if opts.compare is not None:
            other = Path(tmp) / "other"
            other.mkdir()
            sources["other"] = compiled_source(opts.compare.resolve(), str(other))
        envs = {
            label: bench_env(dict(os.environ))
            | {"PYTHONPATH": str(src), "XDG_DATA_HOME": tmp, "RIG_API_TOKEN": "bench"}
            for label, src in sources.items()
        }
        counter = itertools.count()

        def new_url() -> str:
            return f"sqlite:///{tmp}/new{next(counter)}.db"

        head = {label: new_url() for label in sources}
        for label, url in head.items():  # made by each source itself
            cpu_of([*OPEN, url], envs[label], tmp)
        commands = {
            "python -c pass": lambda label: ([sys.executable, "-c", "pass"], envs[label]),
            "open new": lambda label: ([*OPEN, new_url()], envs[label]),
            "open at head": lambda label: ([*OPEN, head[label]], envs[label]),
            "rig runs new": lambda label: (
                [*RIG, "runs"],
                envs[label] | {"RIG_DATABASE_URL": new_url()},
            ),
        }
        cpus: dict[str, dict[str, list[float]]] = {label: {} for label in sources}
        for name, command in commands.items():
            for _ in range(opts.runs):
                for label in sources:  # alternating: both sources see the same load
                    argv, env = command(label)
                    cpus[label].setdefault(name, []).append(cpu_of(argv, env, tmp))
        out: dict = {"runs": opts.runs, "sources": {k: str(v) for k, v in sources.items()}}
        if opts.compare is not None:
            out["sources"]["other"] = str(opts.compare.resolve())
        medians = {
            label: {name: statistics.median(values) for name, values in by_name.items()}
            for label, by_name in cpus.items()
        }
        for label, by_name in medians.items():
            out[label] = {f"{name} cpu_s": round(value, 3) for name, value in by_name.items()}
            out[label]["new database over at head cpu_s"] = round(
                by_name["open new"] - by_name["open at head"], 3
            )
        if opts.compare is not None:
            out["ratios"] = {
                name: round(medians["this"][name] / medians["other"][name], 3) for name in commands
            }
        out["cpu_load_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
