"""``rig`` on a fresh database in a test's folder: in this process (``run_in_process``:
store-only commands, answered as a fresh process would answer) or as a real subprocess.

A ``rig`` subprocess costs an interpreter start and the imports of its command (0.5 s of
CPU, 2 s with SciPy); commands that drive the rig, bind ports or take signals stay real
subprocesses in the tests that are about them (tests/procedures/test_cli.py, …)."""

from __future__ import annotations

import json
import logging
import os
import re
import subprocess
import sys
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path

from click.testing import CliRunner


class _Kept(logging.Handler):
    """Keeps the records it is handed."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def run_in_process(
    argv: list[str], *, cwd: Path, env: dict[str, str]
) -> subprocess.CompletedProcess[str]:
    """``rig argv`` through ``api.cli.main.main`` in this process, in ``cwd`` with exactly
    the environment ``env``. Its stderr is what a fresh process would print: the command's
    own lines, then each log record of WARNING and above (Python's last-resort handler),
    each warning Python's default filters show, and the traceback of an escaped exception."""
    from api.cli.main import main

    changes: dict[str, str | None] = {k: v for k, v in env.items() if os.environ.get(k) != v}
    changes |= {k: None for k in os.environ if k not in env}
    kept = _Kept()
    root = logging.getLogger()
    pymodbus = logging.getLogger("pymodbus")  # main() quiets it for its process
    level = pymodbus.level
    before = Path.cwd()
    root.addHandler(kept)
    os.chdir(cwd)
    try:
        with warnings.catch_warnings(record=True) as shown:
            warnings.resetwarnings()  # Python's defaults, not the test run's filters
            warnings.simplefilter("default")
            for quiet in (DeprecationWarning, PendingDeprecationWarning, ImportWarning):
                warnings.filterwarnings("ignore", category=quiet)
            warnings.filterwarnings("ignore", category=ResourceWarning)
            result = CliRunner().invoke(main, argv, env=changes, catch_exceptions=True)
    finally:
        os.chdir(before)
        root.removeHandler(kept)
        pymodbus.setLevel(level)
    extra = [f"{r.levelname}: {r.getMessage()}" for r in kept.records]
    extra += [f"{w.category.__name__}: {w.message}" for w in shown]
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        assert result.exc_info is not None
        extra.append("".join(traceback.format_exception(*result.exc_info)))
    stderr = result.stderr + "".join(f"{line}\n" for line in extra)
    return subprocess.CompletedProcess(argv, result.exit_code, result.stdout, stderr)


class RigCli:
    """``rig(*argv, code=0)`` runs ``rig argv`` in ``folder`` (its own SQLite database,
    ``db``, and data folder), checks the exit code and that no traceback was printed; in
    this process (``run_in_process``), or as a subprocess with ``as_subprocess=True``."""

    def __init__(self, folder: Path, *, as_subprocess: bool = False) -> None:
        self.folder = folder
        self.db = f"sqlite:///{folder}/rig.db"
        self.env = os.environ | {"RIG_DATABASE_URL": self.db, "XDG_DATA_HOME": str(folder)}
        self.as_subprocess = as_subprocess

    def __call__(self, *argv: str, code: int = 0) -> subprocess.CompletedProcess:
        if self.as_subprocess:
            proc = subprocess.run(
                [sys.executable, "-m", "api.cli.main", *argv],
                cwd=self.folder, env=self.env, capture_output=True, text=True, timeout=120,
                check=False,
            )  # fmt: skip
        else:
            proc = run_in_process(list(argv), cwd=self.folder, env=self.env)
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
