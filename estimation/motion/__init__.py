"""The one single-DOF equation of motion: its term library, integrator, fit, term search and
the entry for a free decay (``estimate_decay``)."""

from estimation.errors import EstimationFailed
from estimation.motion.decay import DecayResult, estimate_decay, estimate_records
from estimation.motion.records import Record

__all__ = ["DecayResult", "EstimationFailed", "Record", "estimate_decay", "estimate_records"]
