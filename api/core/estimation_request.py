"""What an estimation is asked with, declared once for ``POST /api/jobs/estimation`` and
``rig estimate``: each field with its range and help, and its command-line spelling
(:class:`~daq.procedures.procedure_request.Flag`; ``api.cli.options`` derives the options)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from daq.procedures.flag import Flag
from daq.procedures.procedure_request import StrictRequest
from daq.procedures.run_kinds import KINDS, all_methods

#: The methods each estimator offers beside output-error, in words.
_OTHER_METHODS = "; ".join(
    f"{k}: {', '.join(s.estimator.methods)}" for k, s in KINDS.items() if s.estimator
)


class EstimationRequest(StrictRequest):
    """Stored runs of one kind and how to fit them."""

    run_ids: list[str] = Field(
        min_length=1, max_length=50, description="Tow or spin run ids, or pendulum run ids."
    )
    method: Annotated[
        Literal[all_methods()],  # type: ignore[valid-type]
        Flag("--method"),
    ] = Field(
        "output-error",
        description="output-error (joint over the runs) for every kind; the others per kind "
        f"({_OTHER_METHODS}), checked per run. A pendulum's methods are all reported; this "
        "picks the headline.",
    )
    search_effects: Annotated[
        bool,
        Flag(
            "--no-effects", when_set=False,
            help="Fit the base model only; skip the search for missing effects.",
        ),
    ] = Field(True, description="Trace the residual to effects the base model lacks.")  # fmt: skip
    exclude_outliers: Annotated[
        bool, Flag("--exclude-outliers", when_set=True)
    ] = Field(
        False,
        description="Leave out repeats Chauvenet's criterion flags as outlying (tows, spins, "
        "pendulums and free decays; docs/uncertainty.md); by default they are flagged and "
        "kept. The result names what was left out and why.",
    )  # fmt: skip
