"""Start-up time of the ``rig`` CLI against a bare interpreter.

Runs each command ``--runs`` times (default 7) as a fresh process and prints one JSON
document with the median wall time of each, and of each minus ``python -c pass``.
Light commands must not import numpy, scipy, matplotlib, fastapi, sqlalchemy or
pymodbus unless they use them; ``imports`` lists which of those each one loaded.
"""

from __future__ import annotations

import argparse
import compileall
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HEAVY = ("numpy", "scipy", "matplotlib", "fastapi", "sqlalchemy", "pymodbus", "pydantic")
RIG = [
    sys.executable,
    "-c",
    "import sys; from api.cli.main import main; sys.argv[0] = 'rig'; main()",
]


#: What an installed ``rig`` imports from its own source (``pyproject.toml``'s packages).
PACKAGES = ("api", "daq", "estimation", "thrusters", "fixtures")


def compiled_source(src: Path | None, tmp: str) -> Path:
    """The source to time, byte-compiled as an install leaves it: this checkout compiled in
    place (``__pycache__``, ignored by git), another checkout (``--src``) copied to ``tmp``
    and compiled there (no byte code left in it). Without this, a ``PYTHONDONTWRITEBYTECODE``
    environment makes every process compile every module it imports (``rig estimate``: 4.9 s
    of CPU → 11 s with no byte code at all), and the figures time the compiler."""
    root = Path(__file__).resolve().parents[1]
    if src is not None and src.resolve() != root:
        copy = Path(tmp) / "src"
        for name in (*PACKAGES, "pyproject.toml"):
            if (src / name).is_dir():
                skip = shutil.ignore_patterns("__pycache__")
                shutil.copytree(src / name, copy / name, ignore=skip)
            elif (src / name).exists():
                shutil.copy2(src / name, copy / name)
        root = copy
    for name in PACKAGES:
        if (root / name).is_dir():
            compileall.compile_dir(root / name, quiet=1)
    return root


def bench_env(env: dict[str, str]) -> dict[str, str]:
    """``env`` for the timed processes: byte code read as compiled (``compiled_source``),
    never from a cache prefix that holds none."""
    dropped = ("PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX")
    return {k: v for k, v in env.items() if k not in dropped}


def timed(argv: list[str], env: dict[str, str], runs: int) -> tuple[float, float]:
    """Median wall time and median CPU time (user + system) of ``runs`` fresh processes;
    CPU time is the figure to trust on a loaded machine."""
    walls, cpus = [], []
    for _ in range(runs):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run(argv, env=env, cwd=env["XDG_DATA_HOME"], capture_output=True, check=False)
        walls.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpus.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return statistics.median(walls), statistics.median(cpus)


def heavy_imports(args: list[str], env: dict[str, str]) -> list[str]:
    """Which HEAVY packages the command imported (from ``-X importtime``)."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", *RIG[1:], *args], env=env, cwd=env["XDG_DATA_HOME"],
        capture_output=True,
        text=True, check=False,
    )  # fmt: skip
    names = {line.rsplit("|", 1)[-1].strip() for line in proc.stderr.splitlines()}
    return [h for h in HEAVY if h in names]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument(
        "--src", type=Path, help="Time another checkout's code (e.g. before a change)."
    )
    opts = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src = {"PYTHONPATH": str(compiled_source(opts.src, tmp))} if opts.src else {}
        if not opts.src:
            compiled_source(None, tmp)
        env = (
            bench_env(dict(os.environ))
            | src
            | {
                "RIG_DATABASE_URL": f"sqlite:///{tmp}/rig.db",
                "XDG_DATA_HOME": tmp,
                "RIG_API_TOKEN": "bench",
            }
        )
        subprocess.run([*RIG, "runs"], env=env, cwd=tmp, capture_output=True, check=True)  # the db
        baseline, baseline_cpu = timed([sys.executable, "-c", "pass"], env, opts.runs)
        commands = {
            "rig --help": ["--help"],
            "rig token": ["token"],
            "rig show --help": ["show", "--help"],
            "rig runs": ["runs"],
            "rig show 0000": ["show", "0000"],
        }
        out = {
            "source": str(opts.src or Path(__file__).resolve().parents[1]),
            "runs": opts.runs,
            "python_c_pass_s": round(baseline, 3),
            "python_c_pass_cpu_s": round(baseline_cpu, 3),
            "commands": {},
        }
        for label, args in commands.items():
            median, cpu = timed([*RIG, *args], env, opts.runs)
            out["commands"][label] = {
                "median_s": round(median, 3),
                "over_python_s": round(median - baseline, 3),
                "cpu_s": round(cpu, 3),
                "cpu_over_python_s": round(cpu - baseline_cpu, 3),
                "imports": heavy_imports(args, env),
            }
        out["cpu_load_1min"] = round(os.getloadavg()[0], 2)
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
