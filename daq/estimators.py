"""Per kind, how its stored runs are estimated: one :class:`Estimator` a registry entry
(``daq.procedures.run_kinds``) holds — its loader, its fit, its methods and its report.

Runs of kinds that share an estimator are fitted together (a tow and a spin share the axis
estimator but are two axes: ``api.core.estimation_job`` refuses to mix them). The estimation
code is imported when a fit runs, never at import (``rig --help`` stays light).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from daq.store import RunInfo, Store
    from estimation.design.planning_envelope import RigEnvelope
    from estimation.uncertainty.budget import Budget


#: The method every estimator takes, as the browser's menu words it.
OUTPUT_ERROR = "output error (joint, default)"


@dataclass(frozen=True)
class Estimator:
    """How runs are estimated.

    ``load(store, records)``: the stored runs as the fit takes them, checked (``ValueError``
    naming the run and field, before anything is fitted), from their records as the estimate
    read them once (``api.core.estimation_job.stored_runs``) and their samples in ``store``;
    ``fit(runs, method, search, envelope, exclude_outliers)``: the result (``to_json()``,
    its ``runs`` those actually fitted; ``envelope``: the rig's tests, ``estimation.design``,
    so the advice it gives names runs the rig can make; None for imports;
    ``exclude_outliers``: leave out the repeats Chauvenet's criterion flags, every estimator
    alike); ``subject``: what a failed fit names ("surge", "roll swing");
    ``report(result, runs, folder, budget)``: the report's files (``budget``: the result's
    budget document, shown beside its summary, or None); ``methods``: the methods it
    takes, the first the default (a callable, so the estimation code loads on first use),
    ``method_labels`` how the browser's menu words them.

    What an estimator offers beyond the fit is a field, ``None`` where it offers nothing,
    so the job calls it without naming the estimator:
    ``budget(records, runs, result)`` → the result's GUM budget (``Budget``; None: no fit
    to budget), which the job adds to the result's document and report, the theory
    comparison reads and a campaign plans on (``api.core.campaign_fit``); ``compares_theory``:
    its results are compared with the hull's theory (``api.core.theory_job``: a tow or
    spin's added mass and damping); ``units_of()`` → per axis (or dof) its results may be
    on, the unit of each quantity they report (``{"surge": {"inertia": "kg", …,
    "position": "m"}}``; a page shows them beside the result's numbers,
    ``GET /api/kinds``)."""

    name: str
    #: How messages name its runs: "tow/spin".
    runs: str
    methods_of: Callable[[], tuple[str, ...]]
    load: Callable[[Store, Sequence[RunInfo]], list[Any]]
    fit: Callable[[list[Any], str, bool, RigEnvelope | None, bool], Any]
    subject: Callable[[list[Any]], str]
    report: Callable[[Any, list[Any], Path, dict[str, Any] | None], list[Path]] | None = None
    #: method → how the browser's method menu words it (a method missing: its name).
    method_labels: dict[str, str] = field(default_factory=dict)
    budget: Callable[[Sequence[RunInfo], list[Any], Any], Budget | None] | None = None
    compares_theory: bool = False
    units_of: Callable[[], dict[str, dict[str, str]]] = dict

    @property
    def methods(self) -> tuple[str, ...]:
        return self.methods_of()


def _axis_methods() -> tuple[str, ...]:
    from estimation import METHODS

    return tuple(METHODS)


def _axis_units() -> dict[str, dict[str, str]]:
    from estimation.axis.crosscheck_comparison import UNITS as COMPARED
    from estimation.axis.tow_section import UNITS

    return {axis: UNITS[axis] | COMPARED[axis] for axis in UNITS}


def _axis_load(store: Store, records: Sequence[RunInfo]) -> list[Any]:
    from daq.body_mass import with_body_inertia
    from daq.run_data import run_data_of
    from estimation.data.run_arrays import validate_runs

    # The body's own mass the tow declares: an inertia fitted below it is flagged.
    runs = [with_body_inertia(run_data_of(store, run), run) for run in records]
    validate_runs(runs)
    return runs


def _axis_fit(
    runs: list[Any],
    method: str,
    search: bool,
    envelope: RigEnvelope | None = None,
    exclude_outliers: bool = False,
) -> Any:
    from estimation import estimate

    return estimate(
        runs,
        method=method,
        search_effects=search,
        envelope=envelope,
        exclude_outliers=exclude_outliers,
    )


def _axis_budget(records: Sequence[RunInfo], runs: list[Any], result: Any) -> Budget | None:
    """Every method's budget, its repeatability from the result's repeats."""
    from daq.axis_budget import fitted_budget

    return fitted_budget(records, runs, result, result.repeats)


def _axis_report(
    result: Any, runs: list[Any], folder: Path, budget: dict[str, Any] | None
) -> list[Path]:
    from estimation.axis.tow_report import write_report  # matplotlib: load only when asked

    return write_report(result, runs, folder, budget)


#: Tow and spin runs: the axis model (``estimation.axis.tow_estimate``).
AXIS = Estimator(
    name="axis",
    runs="tow/spin",
    methods_of=_axis_methods,
    load=_axis_load,
    fit=_axis_fit,
    subject=lambda runs: str(runs[0].axis),
    report=_axis_report,
    method_labels={
        "output-error": OUTPUT_ERROR,
        "ls-steady": "seed: steady state + curve fit",
        "ls-curvefit": "seed: curve fit",
        "ls-raw": "seed: raw differences",
    },
    budget=_axis_budget,
    compares_theory=True,
    units_of=_axis_units,
)


def _pendulum_methods() -> tuple[str, ...]:
    from estimation.pendulum import PENDULUM_METHODS  # not the estimation: a list of names

    return PENDULUM_METHODS


def _pendulum_load(store: Store, records: Sequence[RunInfo]) -> list[Any]:
    from daq.run_data import pendulum_data_of
    from estimation.pendulum.pendulum_estimate import validate_pendulum_runs

    swings = [pendulum_data_of(store, run) for run in records]
    validate_pendulum_runs(swings)
    return swings


def _pendulum_fit(
    runs: list[Any],
    method: str,
    search: bool,
    envelope: RigEnvelope | None = None,
    exclude_outliers: bool = False,
) -> Any:
    from estimation.pendulum.pendulum_estimate import estimate_pendulum

    return estimate_pendulum(runs, method=method, search=search, exclude_outliers=exclude_outliers)


def _pendulum_budget(records: Sequence[RunInfo], runs: list[Any], result: Any) -> Budget:
    """The GUM budget of the headline coefficients (output error's, or a seed method's)."""
    from estimation.pendulum.pendulum_estimate import pendulum_budget

    return pendulum_budget(result)


def _pendulum_report(
    result: Any, runs: list[Any], folder: Path, budget: dict[str, Any] | None
) -> list[Path]:
    from estimation.pendulum.pendulum_report import write_pendulum_report

    return write_pendulum_report(result, folder, budget)


#: Pendulum free decays: α, β of the swing axis (``estimation.pendulum.pendulum_estimate``).
PENDULUM = Estimator(
    name="pendulum",
    runs="pendulum",
    methods_of=_pendulum_methods,
    load=_pendulum_load,
    fit=_pendulum_fit,
    subject=lambda runs: f"{runs[0].axis} swing",
    report=_pendulum_report,
    budget=_pendulum_budget,
    method_labels={
        "output-error": OUTPUT_ERROR,
        "damped-fit": "pendulum: damped sinusoid fit (least squares)",
        "log-decrement": "pendulum: log decrement (component method)",
        "equation-error": "pendulum: equation-error LS",
    },
)
