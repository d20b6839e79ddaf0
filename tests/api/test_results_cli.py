"""``rig results``: the stored results listed by run, and two compared side by side (the
same document as ``GET /api/results/compare``), with one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from daq.store import Store
from tests.support.cli import RigCli

CSV = "t,position\n0,0\n0.1,0.01\n0.2,0.03\n"


@pytest.fixture
def rig(tmp_path: Path) -> RigCli:
    (tmp_path / "day1.csv").write_text(CSV)
    return RigCli(tmp_path)


def _doc(value: float, std: float) -> dict:
    return {"axis": "surge", "method": "output-error",
            "coefficients": {"inertia": {"value": value, "std": std}}}  # fmt: skip


def test_results_are_listed_and_compared(rig) -> None:
    run = rig("import", "day1.csv", "--kind", "tow", "--force", "10").stdout.strip()
    other = rig("import", "day1.csv", "--kind", "tow", "--force", "20").stdout.strip()
    store = Store(rig.db)
    try:
        first = store.add_result([run], "estimation", _doc(10.0, 0.3))
        second = store.add_result([other], "estimation", _doc(11.0, 0.4))
    finally:
        store.close()

    listed = json.loads(rig("results", "--json", "--run", run[:8]).stdout)
    assert [r["id"] for r in listed] == [first]
    text = rig("results").stdout
    assert f"#{second}" in text.splitlines()[0] and "surge tow test / output-error" in text

    compared = json.loads(rig("results", "--compare", str(first), str(second), "--json").stdout)
    (row,) = compared["coefficients"]
    assert row["difference_sigma"] == [None, pytest.approx(1.0 / 0.5)]
    table = rig("results", "--compare", str(first), str(second)).stdout
    assert f"#{second}−#{first} (σ)" in table and "10 ± 0.6 (2σ)" in table and "2 " in table

    assert "--compare" in rig("results", "--compare", str(first), code=2).stderr
    assert "no result with id 999" in rig("results", "--compare", str(first), "999", code=2).stderr
    assert "without --compare" in rig("results", "12", "13", code=2).stderr


def test_results_take_the_routes_filters_by_day_and_kind(rig) -> None:
    """The filters are GET /api/results' (api.core.result_filter): a day window in this
    computer's zone and the kind, refused in one line naming the option."""
    run = rig("import", "day1.csv", "--kind", "tow", "--force", "10").stdout.strip()
    store = Store(rig.db)
    try:
        made = store.add_result([run], "estimation", _doc(10.0, 0.3))
    finally:
        store.close()
    assert [r["id"] for r in json.loads(rig("results", "--since", "today", "--json").stdout)] == [
        made
    ]
    assert json.loads(rig("results", "--until", "yesterday", "--json").stdout) == []
    assert json.loads(rig("results", "--kind", "calibration", "--json").stdout) == []
    assert (
        "--since: 'someday' is not allowed" in rig("results", "--since", "someday", code=2).stderr
    )
