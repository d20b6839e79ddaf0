"""A stored result says what it is of (``subject``), read in one place for the page's list
and ``rig results``: a pendulum's is never a tow's, a settling sphere's names its heave."""

from __future__ import annotations

import pytest

from api.core.result_subject import subject
from tests.api.conftest import AUTH

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime

#: (kind, document as its producer stores it (the keys that say what it is), subject): schema 2
#: documents name their kind; schema 1's (stored before the one result type) still read.
STORED = [
    ("estimation", {"kind": "tow", "axis": "surge", "dof": "heave", "method": "output-error"},
     "heave tow test / output-error"),
    ("estimation", {"kind": "pendulum", "analysis": "pendulum", "axis": "sway",
                    "method": "damped-fit"}, "sway pendulum free-decay test / damped-fit"),
    ("estimation", {"kind": "decay", "dof": "heave", "method": "output-error"},
     "heave free decay / output-error"),
    ("estimation", {"axis": "surge", "method": "output-error"}, "surge tow test / output-error"),
    ("estimation", {"axis": "surge", "dof": "heave", "method": "output-error"},
     "heave tow test / output-error"),
    ("estimation", {"axis": "yaw", "method": "equation-error"}, "yaw spin test / equation-error"),
    ("estimation", {"analysis": "pendulum", "axis": "surge", "method": "output-error"},
     "surge pendulum free-decay test / output-error"),
    ("estimation", {"kind": "decay", "dof": "roll"}, "roll free decay"),
    ("calibration", {"thrusters": []}, "thrust calibration"),
    ("crosscheck", {"axis": "surge"}, "surge cross-check"),
    ("estimation", {}, "—"),
]  # fmt: skip


@pytest.mark.parametrize(("kind", "data", "expected"), STORED, ids=[s[2] for s in STORED])
def test_each_kind_of_result_is_named_for_what_it_is_of(kind, data, expected):
    assert subject(kind, data) == expected


def test_the_results_list_and_one_result_carry_the_subject(client, tow_job):
    store = client.app.state.service.store
    doc = {"analysis": "pendulum", "axis": "surge", "method": "output-error"}
    result_id = store.add_result(tow_job["run_ids"], "estimation", doc)
    listed = client.get("/api/results", params={"run": tow_job["run_ids"][0]}, headers=AUTH)
    assert listed.status_code == 200, listed.text
    mine = next(r for r in listed.json() if r["id"] == result_id)
    assert mine["subject"] == "surge pendulum free-decay test / output-error"
    one = client.get(f"/api/results/{result_id}", headers=AUTH).json()
    assert one["subject"] == mine["subject"]
