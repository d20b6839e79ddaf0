"""Per-axis models, estimators, effect library, residual diagnostics and reports.

Works on runs as arrays plus metadata (``RunData``); imports nothing from the device side.
"""

from estimation.axis.estimate import METHODS, estimate
from estimation.axis.result import EffectEstimate, Estimate, EstimationResult
from estimation.data.runs import RunData
from estimation.errors import EstimationFailed
from estimation.motion.decay import DecayResult, estimate_decay, estimate_records
from estimation.thrust.curve import ThrustCurve, fit_thrust_curve

__all__ = [
    "METHODS",
    "DecayResult",
    "EffectEstimate",
    "Estimate",
    "EstimationFailed",
    "EstimationResult",
    "RunData",
    "ThrustCurve",
    "estimate",
    "estimate_decay",
    "estimate_records",
    "fit_thrust_curve",
]
