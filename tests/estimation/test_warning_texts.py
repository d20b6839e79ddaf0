"""Warnings name a cause the record's kind can have, in the words of the rig and the user
(issue 31): no "negative damping, which a passive body cannot have", no internal words, no
reverse run for a decay, the DOF as imported."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from estimation.axis.estimate import physical_warnings
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
