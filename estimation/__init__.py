"""Per-axis models, estimators, effect library, residual diagnostics and reports.

Works on runs as arrays plus metadata (``RunData``); imports nothing from the device side.
The names below are imported on first use (``__getattr__``), so a process that needs one
light submodule (``estimation.report_numbers``, ``estimation.scale``) does not load SciPy's
signal, statistics and optimisation stacks with it: ``rig tow`` starts about a second
sooner.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from estimation.axis import METHODS
    from estimation.axis.tow_estimate import estimate
    from estimation.data.run_arrays import RunData
    from estimation.errors import EstimationFailed
    from estimation.motion.decay_estimate import estimate_decay, estimate_records
    from estimation.motion.decay_section import DecayResult
    from estimation.motion.estimation_result import EffectEstimate, EstimationResult
    from estimation.thrust.curve import ThrustCurve, fit_thrust_curve

#: Where each public name lives: imported from there on first use.
_HOME = {
    "METHODS": "axis",
    "estimate": "axis.tow_estimate",
    "EffectEstimate": "motion.estimation_result",
    "EstimationResult": "motion.estimation_result",
    "RunData": "data.run_arrays",
    "EstimationFailed": "errors",
    "DecayResult": "motion.decay_section",
    "estimate_decay": "motion.decay_estimate",
    "estimate_records": "motion.decay_estimate",
    "ThrustCurve": "thrust.curve",
    "fit_thrust_curve": "thrust.curve",
}


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'estimation' has no attribute {name!r}")
    return getattr(import_module(f"estimation.{home}"), name)


__all__ = [
    "METHODS",
    "DecayResult",
    "EffectEstimate",
    "EstimationFailed",
    "EstimationResult",
    "RunData",
    "ThrustCurve",
    "estimate",
    "estimate_decay",
    "estimate_records",
    "fit_thrust_curve",
]
