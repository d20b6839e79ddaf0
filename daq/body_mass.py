"""The body's own inertia a tow declares (a run on an axis whose inertia is a mass:
``AxisTerms.inertia_is_mass``), for the estimator's physical check (an identified inertia
m + m_a below the body's own mass m is not physical and is flagged).

Where it comes from, first found: the run's ``dry_mass_kg`` parameter (an import's
``--dry-mass``), its ``displacement_kg`` (``--displacement``: the mass of a floating body,
ρ·V), the ``[vehicle] dry_mass_kg`` of the rig file stored with the run. A spin's body
inertia is in kg·m², which none of these is: None for a spin.
"""

from __future__ import annotations

import math
from dataclasses import replace

from daq.config import RigConfigError, parse_rig_text
from daq.store import RunInfo
from daq.vocabulary import AXES
from estimation.data.run_arrays import RunData

#: Run parameters that declare the body's own mass (kg), in the order they are taken.
BODY_MASS_PARAMETERS = ("dry_mass_kg", "displacement_kg")


def declared_body_mass(run: RunInfo) -> float | None:
    """The body's own mass (kg) a tow declares (module docstring), else None."""
    terms = AXES.get(run.kind)
    if terms is None or not terms.inertia_is_mass:
        return None
    for key in BODY_MASS_PARAMETERS:
        value = run.parameters.get(key)
        if isinstance(value, int | float) and math.isfinite(value) and value > 0:
            return float(value)
    if not run.rig_toml:
        return None
    try:
        rig = parse_rig_text(run.rig_toml, f"run {run.id} rig file")
    except RigConfigError:
        return None  # loading the run names an unreadable rig file itself
    return rig.vehicle.dry_mass_kg


def with_body_inertia(data: RunData, run: RunInfo) -> RunData:
    """``data`` with ``body_inertia`` set to the tow's declared mass (unchanged if none)."""
    mass = declared_body_mass(run)
    return data if mass is None else replace(data, body_inertia=mass)
