"""The 2D ship section floating in regular waves (``../shared/data/real/ship2d-regular-waves``,
source, units and published values in its README; read from there, never copied): sway with
the measured rig force as a per-sample drive. Its own module: the two whole-record fits are
the longest estimation tests, and a module is one unit of the suite's scheduling."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from estimation import RunData, estimate
from estimation.uncertainty import TowRefits, uncertainty_budget
from tests.support.shared_data import shared_file


def _csv(folder: str, name: str) -> pd.DataFrame:
    return pd.read_csv(shared_file("real", folder, name))


def _ship2d_run() -> RunData:
    """The floating section's sway, the measured rig force as a per-sample drive."""
    d = _csv("ship2d-regular-waves", "ship2d_3111_2_20Hz.csv")
    return RunData(
        "3111_2",
        "surge",
        d.t.to_numpy(),
        d.position.to_numpy(),
        drive=d.force_sway_N.to_numpy(),
        t_release=0.0,
    )


@pytest.mark.slow
def test_ship2d_wave_forcing_is_unexplained_periodic_structure():
    run = _ship2d_run()
    r = estimate([run], n_bootstrap=0)
    u = r.section.unexplained
    assert u is not None and u.structured
    assert u.period is not None and u.period.domain == "time"
    assert u.period.value == pytest.approx(0.802, rel=0.05)
    assert any("0.79" in w or "0.80" in w for w in r.warnings)
    # the tow model cannot follow this record: its fit runs to the finest step the simulator
    # takes (a faster trial counts as diverged) and the result says the inertia is not seen
    assert any("finest step" in w for w in r.warnings)
    # a fit held by that limit determines nothing: no σ anywhere, and no U in the budget
    # (K_Q came out 4003 ± 0.01 N·s²/m², a σ from the wall, not from the data)
    doc = r.to_json()
    assert all(c["std"] is None for c in doc["coefficients"].values())
    assert all(e["std"] is None for e in doc["effects"])
    # each says so in a whole sentence: what would determine it (it ended "…would")
    unknown = [w for w in r.warnings if "is not identified by these runs (no σ)" in w]
    assert {w.split()[0] for w in unknown} >= set(doc["coefficients"]), r.warnings
    assert all(w.endswith("or a run at another force would determine it") for w in unknown)
    budget = uncertainty_budget(r, TowRefits([run], r, None), None).to_json()["coefficients"]
    assert all(c["expanded_uncertainty"] is None for c in budget.values())
    assert all(c["reported"].endswith("(not identified: no U)") for c in budget.values())
    # the wave's force reverses to the record's end: no steady speed is claimed for it
    assert not any(c["name"].startswith("terminal speed") for c in doc["well_determined"])


@pytest.mark.slow
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_ship2d_with_the_release_found_in_the_data_never_overflows():
    """The import path: the release found from the motion onset and refined by the fit,
    then the effect search; before, both overflowed ("array must not contain infs")."""
    from estimation.data.run_arrays import windowed_run

    run = _ship2d_run()
    r = estimate([windowed_run(run)], n_bootstrap=0)
    assert r.section.unexplained is not None and r.section.unexplained.structured
    assert r.possibly_biased is True  # the one flag every kind's result carries
    assert all(np.isfinite(c.value) for c in r.coefficients.values())
