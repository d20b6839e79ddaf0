"""``rig estimate``'s summary (``api.cli.estimate.summary_lines``) reads the one result
document section by section, whatever the kind: here its ``bootstrap`` section, on a heave
decay of three records from scipy's solve_ivp (``tests.estimation.term_cases.decay``)."""

from __future__ import annotations

from api.cli.estimate import summary_lines
from estimation.motion.decay_estimate import estimate_records
from estimation.motion.records import Record
from tests.estimation.term_cases import decay


def test_rig_estimate_prints_the_bootstrap_spread_beside_the_fit():
    """Each coefficient's spread over the draws, with its unit and the draws used; a
    single record has no bootstrap and no such line."""
    records, truth = [], {}
    for seed in (1, 2, 3):
        t, x, truth = decay("143kg", seed)
        records.append(Record(f"r{seed}", t, x))
    given = dict(known_inertia=truth["known"], stiffness=truth["k"])
    doc = estimate_records(records, "heave", n_bootstrap=8, **given).to_json() | {"result_id": 7}
    (line,) = [s for s in summary_lines(doc) if s.lstrip().startswith("bootstrap σ")]
    boot = doc["bootstrap"]
    assert f"({boot['used']} of 8 draws)" in line
    assert f"inertia {boot['std']['inertia']:.2g} kg" in line
    one = estimate_records(records[:1], "heave", **given).to_json() | {"result_id": 8}
    assert not [s for s in summary_lines(one) if "bootstrap" in s]
