"""EstimationResult: coefficients with σ, effects, evidence, and its JSON document."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from estimation.axis.drive_uncertainty import DriveUncertainty
from estimation.axis.reverse import ReverseTest
from estimation.axis.unexplained import Unexplained
from estimation.data.window import WindowReport
from estimation.motion.output_error_fit import MotionFit
from estimation.motion.record_bootstrap import Bootstrap
from estimation.motion.term_search import Step, evidence_json
from estimation.motion.terms import units_of
from estimation.motion.well_determined import Combination
from estimation.report_numbers import Coefficient, finite_or_none, finite_values
from estimation.stats.acceptance_rules import TOW_RULES
from estimation.stats.diagnostics import Whiteness
from estimation.stats.repeatability import RepeatAnalysis

SCHEMA_VERSION = 1


#: Per axis, the unit of each coefficient and of the position and velocity (SI).
UNITS = {axis: units_of(axis) for axis in ("surge", "yaw")}


@dataclass(frozen=True)
class EffectEstimate:
    """An effect found in the data: library name, value ± σ, unit."""

    name: str
    value: float
    std: float
    unit: str

    def to_json(self) -> dict[str, Any]:
        """{name, value, std, unit}."""
        return {
            "name": self.name,
            "value": finite_or_none(self.value),
            "std": finite_or_none(self.std),
            "unit": self.unit,
        }


@dataclass(frozen=True)
class EstimationResult:
    """Everything one estimation produced; ``to_json()`` is the documented document."""

    axis: str
    method: str
    runs: tuple[str, ...]
    coefficients: dict[str, Coefficient]
    coefficients_before: dict[str, Coefficient]
    effects: tuple[EffectEstimate, ...]
    ambiguous: tuple[tuple[str, ...], ...]
    rmse_before: float
    rmse_after: float
    rmse_per_run_before: dict[str, float]
    rmse_per_run_after: dict[str, float]
    correlation_names: tuple[str, ...]
    correlation: np.ndarray
    warnings: tuple[str, ...]
    advice: tuple[str, ...]
    whiteness_before: Whiteness
    whiteness_after: Whiteness
    residual_correlations: dict[str, float]
    force_rmse_per_run_before: dict[str, float] = field(default_factory=dict)
    force_rmse_per_run_after: dict[str, float] = field(default_factory=dict)
    steps: tuple[Step, ...] = ()
    cv_before: float | None = None
    cv_after: float | None = None
    bootstrap: Bootstrap | None = None
    uncertainty: DriveUncertainty | None = None
    #: Per run, the samples fitted and how the release and end were found.
    windows: dict[str, WindowReport] = field(default_factory=dict)
    #: Per thruster-driven run, the thrust law its drive was rebuilt with.
    drive_laws: dict[str, str] = field(default_factory=dict)
    unexplained: Unexplained | None = None
    #: The reverse run that separates friction from bias, when they are ambiguous.
    reverse_test: ReverseTest | None = None
    #: Combinations the data determine well (``motion.well_determined``): terminal speeds.
    well_determined: tuple[Combination, ...] = ()
    #: The runs' repeats and Chauvenet outliers (``axis.tow_repeats``), every kind's shape.
    repeats: RepeatAnalysis | None = None
    #: The degree of freedom as imported (``RunData.dof``: a tow imported as ``heave``);
    #: None: the axis itself. Headings and texts name it (``subject``).
    dof: str | None = None
    fit_before: MotionFit | None = field(default=None, repr=False, compare=False)
    fit_after: MotionFit | None = field(default=None, repr=False, compare=False)

    @property
    def subject(self) -> str:
        """What the fit is of, in the user's words: the imported dof, else the axis."""
        return self.dof or self.axis

    def to_json(self) -> dict[str, Any]:
        """The JSON document (see docs/estimation.md for the schema)."""
        doc: dict[str, Any] = {
            "schema_version": SCHEMA_VERSION,
            "axis": self.axis,
            "method": self.method,
            "runs": list(self.runs),
            "drive_law": dict(self.drive_laws),
            "coefficients": {k: v.to_json() for k, v in self.coefficients.items()},
            "units": dict(UNITS.get(self.axis, {})),
            "coefficients_before": {k: v.to_json() for k, v in self.coefficients_before.items()},
            "effects": [e.to_json() for e in self.effects],
            "well_determined": [c.to_json() for c in self.well_determined],
            "ambiguous": [list(group) for group in self.ambiguous],
            "rmse_before": finite_or_none(self.rmse_before),
            "rmse_after": finite_or_none(self.rmse_after),
            "rmse_per_run_before": finite_values(self.rmse_per_run_before),
            "rmse_per_run_after": finite_values(self.rmse_per_run_after),
            "correlation": {
                "names": list(self.correlation_names),
                "matrix": [
                    [finite_or_none(x) for x in row] for row in np.asarray(self.correlation)
                ],
            },
            "warnings": list(self.warnings),
            "advice": list(self.advice),
            "reverse_test": self.reverse_test.to_json() if self.reverse_test else None,
            "diagnostics": {
                "ljung_box_before": self.whiteness_before.to_json(),
                "ljung_box_after": self.whiteness_after.to_json(),
                "force_rmse_per_run_before": finite_values(self.force_rmse_per_run_before),
                "force_rmse_per_run_after": finite_values(self.force_rmse_per_run_after),
                "residual_correlation_before": finite_values(self.residual_correlations),
            },
            "evidence": evidence_json(
                self.fit_before, self.fit_after, self.cv_before, self.cv_after, self.steps
            ),
            "acceptance_rules": TOW_RULES.to_json(),
            "bootstrap": self.bootstrap.to_json() if self.bootstrap else None,
            "uncertainty": _uncertainty(self.uncertainty),
            "windows": {k: w.to_json() for k, w in self.windows.items()},
            "repeats": self.repeats.to_json() if self.repeats else None,
            "unexplained": self.unexplained.to_json() if self.unexplained else None,
        }
        if self.dof is not None:  # imported as another straight line (a tow's heave)
            doc["dof"] = self.dof
        return doc


def _uncertainty(u: DriveUncertainty | None) -> dict[str, Any] | None:
    if u is None:
        return None
    total = u.std_total
    return {
        "calibration_draws": u.draws,
        "parameters": {
            n: {
                "std_fit": finite_or_none(u.std_fit[n]),
                "std_calibration": finite_or_none(u.std_calibration[n]),
                "std_release_timing": finite_or_none(u.std_release_timing.get(n, 0.0)),
                "std_total": finite_or_none(total[n]),
            }
            for n in u.std_fit
        },
    }
