"""``rig`` as a real subprocess on a fresh database in a test's folder."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path


class RigCli:
    """``rig(*argv, code=0)`` runs ``rig argv`` in ``folder`` (its own SQLite database,
    ``db``, and data folder), checks the exit code and that no traceback was printed."""

    def __init__(self, folder: Path) -> None:
        self.folder = folder
        self.db = f"sqlite:///{folder}/rig.db"
        self.env = os.environ | {"RIG_DATABASE_URL": self.db, "XDG_DATA_HOME": str(folder)}

    def __call__(self, *argv: str, code: int = 0) -> subprocess.CompletedProcess:
        proc = subprocess.run(
            [sys.executable, "-m", "api.cli.main", *argv],
            cwd=self.folder, env=self.env, capture_output=True, text=True, timeout=120,
            check=False,
        )  # fmt: skip
        assert proc.returncode == code, (argv, proc.stdout, proc.stderr)
        assert "Traceback" not in proc.stderr
        return proc


class RigCliText(RigCli):
    """The same, answering stdout (stripped) on success and stderr on an expected failure."""

    def __call__(self, *argv: str, code: int = 0) -> str:  # type: ignore[override]
        proc = super().__call__(*argv, code=code)
        return proc.stdout.strip() if code == 0 else proc.stderr


def answer_prompts(proc: subprocess.Popen, act: Callable[[str], object]) -> tuple[list[str], str]:
    """Play the operator of an interactive ``rig`` command (text mode, stdin and stdout
    piped): for each ``>>> …`` prompt it prints, ``act(prompt)`` does what is asked, then
    Enter is pressed. Returns the prompts and all of stdout, once it ends."""
    assert proc.stdout is not None and proc.stdin is not None
    asked, out = [], []
    for line in proc.stdout:
        out.append(line)
        match = re.match(r">>> (.*)", line)
        if not match:
            continue
        asked.append(match.group(1))
        act(match.group(1))
        proc.stdin.write("\n")
        proc.stdin.flush()
    return asked, "".join(out)


def printed_json(stdout: str) -> dict:
    """The JSON document a ``--json`` command printed after its other lines."""
    return json.loads(stdout[stdout.index("{") :])
