"""The sequence files a browser can start: those in ``fixtures/sequences`` and, after them,
``$RIG_SEQUENCES_DIR``, each with its steps labelled and checked against this rig (a file the
rig cannot run is listed with its problems, not hidden)."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from daq.config import RigConfig
from daq.parameter_labels import labelled
from daq.procedures.params import ParameterError
from daq.procedures.sequence import parse_sequence

#: The sequences that come with the project.
FIXTURE_SEQUENCES = Path(__file__).resolve().parents[2] / "fixtures" / "sequences"
#: A directory of the lab's own sequence files, listed after the fixtures.
SEQUENCES_DIR_ENV = "RIG_SEQUENCES_DIR"


def sequence_files() -> dict[str, Path]:
    """Sequence name (file stem) → file; a later directory does not shadow an earlier one."""
    dirs = [FIXTURE_SEQUENCES]
    extra = os.environ.get(SEQUENCES_DIR_ENV, "").strip()
    if extra:
        dirs.append(Path(extra).expanduser())
    found: dict[str, Path] = {}
    for folder in dirs:
        if folder.is_dir():
            for path in sorted(folder.glob("*.toml")):
                found.setdefault(path.stem, path)
    return found


def describe_sequence(file: str, path: Path, rig: RigConfig) -> dict[str, Any]:
    """One file: its content (the body ``POST /api/jobs/sequence`` takes), its steps
    labelled, the number of runs, and the problems this rig finds (empty: it can start)."""
    try:
        content = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        problem = f"file: not a readable sequence file ({err})"
        empty: dict[str, Any] = {
            "rest_s": None,
            "repeats": None,
            "runs": 0,
            "steps": [],
            "content": None,
        }
        return {"file": file, "name": file, **empty, "problems": [problem]}
    problems: list[str] = []
    try:
        parse_sequence(content, rig, source=file)
    except ParameterError as err:
        problems = err.lines()
    given_steps = content.get("steps")
    raw_steps: list[Any] = given_steps if isinstance(given_steps, list) else []
    steps = [
        {
            "kind": str(step.get("kind", "")),
            "parameters_labelled": [
                p.to_json() for p in labelled({k: v for k, v in step.items() if k != "kind"})
            ],
        }
        for step in raw_steps
        if isinstance(step, dict)
    ]
    rest = content.get("rest_s", 0.0)
    repeats = content.get("repeats", 1)
    repeats = repeats if isinstance(repeats, int) and not isinstance(repeats, bool) else None
    return {
        "file": file,
        "name": str(content.get("name") or file),
        "rest_s": float(rest) if isinstance(rest, int | float) else None,
        "repeats": repeats,
        "runs": len(steps) * (repeats or 1),
        "steps": steps,
        "content": content,
        "problems": problems,
    }


def list_sequences(rig: RigConfig) -> list[dict[str, Any]]:
    """Every sequence file, by name."""
    return [describe_sequence(name, path, rig) for name, path in sequence_files().items()]
