"""``rig campaign`` on the simulated rig (a real subprocess, real time): the planner's first
test runs, the fit is booked in the trail, and the budget stops it, said in one line."""

from __future__ import annotations

import json

import pytest

from tests.support.cli import RigCli

#: Slow lane: one real-time tow on the simulated rig and its fit (about 20 s).
pytestmark = pytest.mark.slow


def test_a_one_run_campaign_runs_the_planners_opening_and_stops_at_its_budget(tmp_path):
    rig = RigCli(tmp_path)
    proc = rig("campaign", "--axis", "surge", "--max-runs", "1", "--json")
    doc = json.loads(proc.stdout)
    assert doc["outcome"] == "budget: 1 of 1 runs used" and doc["runs_used"] == 1
    (entry,) = doc["trail"]
    # the opening: the rig file's largest force (100 N), a hung weight, forward
    assert entry["request"] == {"force_n": 100.0, "drive": "weight"}
    assert entry["before"]["unresolved"] == ["no fit yet"]
    assert set(entry["after"]["expanded_percent"]) == {
        "inertia",
        "linear_damping",
        "quadratic_damping",
    }
    assert entry["run_s"] > 5 and entry["tank_minutes"] > 0.5  # run + the 30 s reset
    shown = json.loads(rig("show", entry["run_id"], "--json").stdout)
    assert shown["metadata"]["campaign"]  # the run says a campaign made it
