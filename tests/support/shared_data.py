"""Published records nobody on the project wrote, read where the project keeps them: the
``shared/data`` folder beside the checkout (``../shared/data`` from the repository root; CI
has it). A missing file skips the test on a laptop and fails it under ``CI=true``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

from tests.conftest import IN_CI

if TYPE_CHECKING:
    from estimation.data.run_arrays import RunData

SHARED_DATA = Path(__file__).resolve().parents[3] / "shared" / "data"


def shared_file(*parts: str) -> Path:
    """``shared/data/<parts>``; skip (or fail under CI=true) when it is not there."""
    path = SHARED_DATA.joinpath(*parts)
    if path.is_file():
        return path
    message = f"published data not found: {path}"
    if IN_CI:
        pytest.fail(message + " (required when CI=true)")
    pytest.skip(message)
    raise AssertionError("unreachable")


def tencate_e1(**window: Any) -> RunData:
    """Ten Cate E1 (``real/tencate-sphere-settling``) as a tow: the net weight 2.6004 mN pulls
    the 1.979 g sphere (its README); ``window`` as ``RunData`` takes it (t_release, t_end)."""
    import pandas as pd

    from estimation.data.run_arrays import RunData

    d = pd.read_csv(shared_file("real", "tencate-sphere-settling", "tencate_E1_tow.csv"))
    return RunData(
        "E1", "surge", d.t.to_numpy(), d.position.to_numpy(), drive=0.0026004,
        body_inertia=0.001979, **window,
    )  # fmt: skip
