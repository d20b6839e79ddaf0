"""Uncertainty of the estimated coefficients in the ITTC 7.5-02-01-01 / GUM form: budgets
(Type A and declared Type B sources, the repeatability of repeat runs), and pre-test
prediction.
See docs/uncertainty.md."""

from estimation.uncertainty.budget import Budget, CoefficientBudget, uncertainty_budget
from estimation.uncertainty.record_refits import RecordRefits
from estimation.uncertainty.sources import SOURCES, Chain, check_tolerances
from estimation.uncertainty.tow_refits import TowRefits

__all__ = [
    "SOURCES",
    "Budget",
    "Chain",
    "CoefficientBudget",
    "RecordRefits",
    "TowRefits",
    "check_tolerances",
    "uncertainty_budget",
]
