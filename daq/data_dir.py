"""Where the rig keeps its files by default (no heavy imports: ``rig token`` uses it)."""

from __future__ import annotations

import os
from pathlib import Path


def default_database_path() -> Path:
    """``$XDG_DATA_HOME/towrig/rig.db`` (``~/.local/share/towrig/rig.db`` by default)."""
    data_home = os.environ.get("XDG_DATA_HOME") or str(Path.home() / ".local" / "share")
    return Path(data_home) / "towrig" / "rig.db"
