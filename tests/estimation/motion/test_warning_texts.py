"""Warnings name a cause the record's kind can have, in the words of the rig and the user
(issue 31): no "negative damping, which a passive body cannot have", no internal words, no
reverse run for a decay, the DOF as imported."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from estimation import estimate
from estimation.axis.tow_estimate import physical_warnings
from estimation.uncertainty import TowRefits, uncertainty_budget
from estimation.uncertainty.sources import Chain
from tests.estimation.term_cases import tow_set


def test_a_linear_damping_at_its_bound_names_causes_a_record_can_have():
    """K_L held at 0 is a drag that grows faster than linearly over the tested speeds (a
    settling sphere at high Re) or a force the model lacks, never "a negative damping, which
    a passive body cannot have" (no body was asked to have one)."""
    fit = SimpleNamespace(
        names=("inertia", "linear_damping", "quadratic_damping"),
        std=np.array([1.0, 0.1, 1.0]),
        at_bound=("linear_damping",),
        value=lambda n: 143.0,
        sigma=lambda n: 1.0,
    )
    (text,) = physical_warnings(fit, tow_set("143kg", 0))
    assert "passive body" not in text and "negative damping" not in text
    assert "faster than linearly with speed" in text and "a force the model lacks" in text


def test_runs_without_a_rig_file_are_not_asked_for_its_tolerances_section():
    """Imported runs (no rig file: no chain) were told "the rig file has no [tolerances]
    section … add [tolerances] to the rig file" of a file they never had; they are told to
    import with a rig file that declares them. Runs with a rig file keep the old advice."""
    runs = tow_set("143kg", seed=300)
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    (note,) = uncertainty_budget(result, TowRefits(runs, result, None), None).notes
    assert note.startswith("Type B not declared: these runs came without a rig file")
    assert "--rig FILE" in note and "has no [tolerances] section" not in note
    (note,) = uncertainty_budget(result, TowRefits(runs, result, Chain(g=9.81)), None).notes
    assert "the rig file has no [tolerances] section" in note


def test_response_descriptions_use_no_internal_words():
    """What a user reads of a response names the manoeuvre, not the project's seed papers
    ("seed 004's Ds")."""
    from estimation.vehicle.response_measures import RESPONSES

    assert [r.name for r in RESPONSES if "seed" in r.description.lower()] == []


def test_imported_runs_are_told_to_import_repeats_not_to_edit_a_sequence():
    """Runs without a rig file were told to "set `repeats` ≥ 3 in the sequence" they never
    ran; they are told to import repeated records (``kind_advice``). A rig's runs keep the
    sequence advice."""
    from estimation.axis.tow_repeats import analyse_tow_repeats

    runs = tow_set("143kg", seed=300)
    result = estimate(runs, search_effects=False, n_bootstrap=0)
    repeats = analyse_tow_repeats(runs)
    notes = uncertainty_budget(result, TowRefits(runs, result, None), None, repeats).notes
    (note,) = [n for n in notes if n.startswith("repeatability not evaluated")]
    assert "sequence" not in note and "import ≥ 3 records of the same condition" in note
    notes = uncertainty_budget(result, TowRefits(runs, result, Chain(g=9.81)), None, repeats).notes
    assert any("`repeats` ≥ 3 in the sequence" in n for n in notes)


def test_the_advice_table_knows_every_kind_and_names_a_wrong_one():
    """Decays and pendulum swings have no drive to reverse; each kind says where a dry
    friction can act on it; an unknown kind is refused naming the kinds there are."""
    import pytest

    from estimation.kind_advice import ADVICE, advice_for

    assert sorted(ADVICE) == ["decay", "import", "pendulum", "spin", "tow"]
    assert advice_for("decay").reverse_run is None and advice_for("pendulum").reverse_run is None
    assert "pivot" in advice_for("pendulum").dry_friction
    with pytest.raises(ValueError, match="kind: got 'sphere', allowed: tow, spin, decay"):
        advice_for("sphere")
