"""One result type for every kind (``estimation.motion.estimation_result``): a tow set's, a
free decay's and a pendulum's estimates are one class, their documents carry the same shared
keys (docs/estimation.md, *JSON document*), each names its kind, and what one kind alone has
comes from its section.

Records from scipy's solve_ivp (``tests.estimation.term_cases``, ``pendulum_synth``), not our
integrator; no search or bootstrap (the document's shape does not depend on them).
"""

from __future__ import annotations

from estimation.axis.tow_estimate import estimate
from estimation.motion.decay_estimate import estimate_decay
from estimation.motion.estimation_result import EstimationResult
from estimation.pendulum.pendulum_estimate import estimate_pendulum
from tests.estimation.pendulum_synth import decay as swing
from tests.estimation.term_cases import decay, tow_set

#: The shared keys docs/estimation.md lists: every kind's document has each of them.
SHARED = {
    "schema_version", "method", "runs", "coefficients", "coefficients_before", "known",
    "labels", "units", "effects", "not_identified", "ambiguous", "alternatives", "well_determined",
    "equivalent_linear_damping", "natural_period_s", "rmse_before", "rmse_after",
    "rmse_per_run_before", "rmse_per_run_after", "noise", "coefficients_possibly_biased",
    "correlation", "diagnostics", "warnings", "advice", "evidence", "acceptance_rules",
    "bootstrap", "repeats", "next_release", "kind",
}  # fmt: skip


def _three() -> dict[str, EstimationResult]:
    t, x, truth = decay("143kg", 1)
    return {
        "tow": estimate(tow_set("143kg", 0), search_effects=False, n_bootstrap=0),
        "decay": estimate_decay(
            t, x, "heave", known_inertia=truth["known"], stiffness=truth["k"], candidates=()
        ),
        "pendulum": estimate_pendulum([swing()], search=False),
    }


def test_every_kind_is_one_type_with_one_document_shape():
    """The three estimates are ``EstimationResult``; each document has every shared key, names
    its kind, is schema 2, and lists every fitted run's error before and after the search."""
    for kind, result in _three().items():
        assert type(result) is EstimationResult, kind
        doc = result.to_json()
        assert doc.keys() >= SHARED, (kind, sorted(SHARED - doc.keys()))
        assert doc["kind"] == kind and doc["schema_version"] == 2
        assert doc["rmse_per_run_after"].keys() == set(result.runs), kind
        assert doc["diagnostics"]["ljung_box_after"]["q"] is not None, kind
        assert doc["correlation"]["names"], kind
        # every output-error fit is judged for structure its terms leave (a bool, not null)
        assert isinstance(doc["coefficients_possibly_biased"], bool), kind


def test_what_one_kind_alone_has_is_its_section_s():
    """A tow's drive windows, a decay's equilibria, a pendulum's methods: in that kind's
    document only, from its section; a shared key a section extends (a tow's force-domain
    diagnostics) keeps the shared entries."""
    docs = {kind: r.to_json() for kind, r in _three().items()}
    assert "windows" in docs["tow"] and "windows" not in docs["decay"]
    assert "equilibrium" in docs["decay"] and "equilibrium" not in docs["pendulum"]
    assert "methods" in docs["pendulum"] and "methods" not in docs["tow"]
    # what a decay was given is stated beside what it identified: the body's own inertia
    # given, the identified inertia is the added one
    known = docs["decay"]["known"]
    assert known["known_inertia"]["value"] == decay("143kg", 1)[2]["known"]
    assert known["known_inertia"]["std"] == 0 and "restoring_spring" in known
    # and the reports name it so, where the key alone would read as the whole inertia
    given = f"{known['known_inertia']['value']:.6g}"
    assert docs["decay"]["labels"] == {"inertia": f"added mass (body's own {given} given)"}
    assert docs["tow"]["labels"] == {} and docs["pendulum"]["labels"] == {}
    tow = docs["tow"]["diagnostics"]
    assert {"ljung_box_before", "ljung_box_after", "force_rmse_per_run_after"} <= tow.keys()
    # the pendulum's engine coefficient is reported under the pendulum's name
    assert "added_mass" in docs["pendulum"]["correlation"]["names"]
    assert "inertia" not in docs["pendulum"]["correlation"]["names"]
