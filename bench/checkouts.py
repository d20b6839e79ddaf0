"""One measurement on several checkouts, alternately (base, ours, base, …), as the benches
that take ``--src DIR ...`` compare them: each checkout byte-compiled and run once untimed
first (as an install leaves it: byte code written, numba's cache filled), then ``repeat``
rounds; each figure's median per checkout, and ours over base where two are given."""

from __future__ import annotations

import statistics
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: The packages a checkout's commands import (byte-compiled first).
PACKAGES = ("api", "daq", "estimation", "thrusters")


def flat(doc: dict[str, Any], prefix: str = "") -> dict[str, float]:
    """The numbers of a nested JSON document by dotted key (``first.wall_s``)."""
    out: dict[str, float] = {}
    for key, value in doc.items():
        if isinstance(value, dict):
            out |= flat(value, f"{prefix}{key}.")
        elif isinstance(value, int | float):
            out[prefix + key] = value
    return out


def alternated(
    sources: list[Path], run: Callable[[Path], dict[str, Any]], repeat: int
) -> dict[str, Any]:
    """``run(src)`` on each checkout, alternately ``repeat`` times, after one untimed run:
    ``{"median": {src: {key: median}}, "runs": {src: [...]}, "ours_over_base": …}`` (a key
    missing from a run counts 0: e.g. a process one checkout does not start)."""
    runs: dict[str, list[dict[str, Any]]] = {str(src): [] for src in sources}
    for src in sources:
        compiled = [sys.executable, "-m", "compileall", "-q", *(str(src / p) for p in PACKAGES)]
        subprocess.run(compiled, check=True, capture_output=True)
        run(src)
    for _ in range(repeat):
        for src in sources:
            runs[str(src)].append(run(src))
    medians = {}
    for src, found in runs.items():
        flats = [flat(r) for r in found]
        keys = sorted({k for f in flats for k in f})
        medians[src] = {k: round(statistics.median(f.get(k, 0.0) for f in flats), 3) for k in keys}
    doc: dict[str, Any] = {"median": medians, "runs": runs}
    if len(sources) == 2:
        base, ours = (medians[str(src)] for src in sources)
        doc["ours_over_base"] = {k: round(ours[k] / base[k], 3) for k in ours if base.get(k)}
    return doc
