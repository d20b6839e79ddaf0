"""The browser UI's page logic, unit-tested without a browser: the Node test runner
(``node --test``) on ``tests/api/static/*.test.js``, in the fast lane. Skips on a laptop
without ``node``, fails under ``CI=true``."""

from __future__ import annotations

import subprocess
from pathlib import Path

from tests.conftest import require_tool

STATIC_TESTS = Path(__file__).parent / "static"


def test_page_logic_passes_nodes_test_runner() -> None:
    node = require_tool("node", "the browser UI's page logic is unit-tested with node --test")
    files = sorted(str(p) for p in STATIC_TESTS.glob("*.test.js"))
    assert files, f"no *.test.js under {STATIC_TESTS}"
    done = subprocess.run(
        [node, "--test", *files], capture_output=True, text=True, timeout=120, check=False
    )
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-2000:]
