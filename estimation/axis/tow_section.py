"""A tow set's or spin's section of the one result (``motion.estimation_result``), and the
units of the axes a tow or spin is on."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from estimation.axis.drive_uncertainty import DriveUncertainty
from estimation.axis.reverse import ReverseTest
from estimation.axis.seed_methods import LeastSquaresFit
from estimation.axis.unexplained import Unexplained
from estimation.data.driven_axes import DRIVEN_AXES
from estimation.data.window import WindowReport
from estimation.motion.estimation_result import EstimationResult
from estimation.motion.terms import units_of
from estimation.report_numbers import finite_or_none, finite_values

#: Per axis, the unit of each coefficient and of the position and velocity (SI).
UNITS = {axis: units_of(axis) for axis in ("surge", "yaw")}


@dataclass(frozen=True)
class TowSection:
    """What a tow set's or spin's result adds to the one result (``motion.estimation_result``):
    the force-domain diagnostics, the calibration draws' budget, each run's window and drive
    law, the residual's character and the reverse run that would separate friction from bias."""

    residual_correlations: dict[str, float]
    force_rmse_per_run_before: dict[str, float] = field(default_factory=dict)
    force_rmse_per_run_after: dict[str, float] = field(default_factory=dict)
    uncertainty: DriveUncertainty | None = None
    #: Per run, the samples fitted and how the release and end were found.
    windows: dict[str, WindowReport] = field(default_factory=dict)
    #: Per thruster-driven run, the thrust law its drive was rebuilt with.
    drive_laws: dict[str, str] = field(default_factory=dict)
    unexplained: Unexplained | None = None
    #: The reverse run that separates friction from bias, when they are ambiguous.
    reverse_test: ReverseTest | None = None
    #: A seed method's own regression (its σ's ν, the budget's Type A); None: output error.
    seed: LeastSquaresFit | None = field(default=None, repr=False, compare=False)

    def to_json(self, result: EstimationResult[Any]) -> dict[str, Any]:
        """The tow's keys: its run kind (``tow``, ``spin``), its axis (and the line as
        imported), drive laws, windows, budget draws, the force-domain diagnostics, the
        residual's character, the reverse run."""
        driven = DRIVEN_AXES.get(result.axis)
        doc: dict[str, Any] = {
            "kind": driven.kind if driven else None,
            "axis": result.axis,
            "drive_law": dict(self.drive_laws),
            "reverse_test": self.reverse_test.to_json() if self.reverse_test else None,
            "diagnostics": {
                "force_rmse_per_run_before": finite_values(self.force_rmse_per_run_before),
                "force_rmse_per_run_after": finite_values(self.force_rmse_per_run_after),
                "residual_correlation_before": finite_values(self.residual_correlations),
            },
            "uncertainty": _uncertainty(self.uncertainty),
            "windows": {k: w.to_json() for k, w in self.windows.items()},
            "unexplained": self.unexplained.to_json() if self.unexplained else None,
        }
        if result.dof is not None:  # imported as another straight line (a tow's heave)
            doc["dof"] = result.dof
        if self.seed is not None:  # a seed method's σ: its ν and the published white σ
            names = self.seed.names
            doc["seed_regression"] = {
                "dof": finite_values(dict(zip(names, self.seed.dof.tolist(), strict=True))),
                "std_white": finite_values(
                    dict(zip(names, self.seed.std_white.tolist(), strict=True))
                ),
                "counts": self.seed.counts,
            }
        return doc


#: A tow set's or a spin's result.
TowResult = EstimationResult[TowSection]


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
