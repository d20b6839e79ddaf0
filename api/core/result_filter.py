"""Which stored results to list: one declaration for ``GET /api/results`` (its query
parameters, ``Annotated[ResultFilter, Query()]``) and ``rig results`` (its options)."""

from __future__ import annotations

from datetime import tzinfo
from typing import Annotated, Any, Literal

from pydantic import Field

from api.core.day_filter import DayFilter
from daq.procedures.flag import Flag


class ResultFilter(DayFilter):
    """Every filter optional; the results listed match all those given (made within the
    day window)."""

    kind: Annotated[
        Literal["estimation", "calibration"] | None,
        Field(description="Only results of this kind."),
        Flag("--kind"),
    ] = None
    run: Annotated[
        str | None,
        Field(max_length=36, description="Made from this run (id or prefix)."),
        Flag("--run", metavar="RUN"),
    ] = None
    vehicle: Annotated[
        str | None,
        Field(max_length=200, description="Made from runs of this vehicle."),
        Flag("--vehicle"),
    ] = None

    def store_filters(self, default_zone: tzinfo | None = None) -> dict[str, Any]:
        """The keyword arguments of ``Store.list_results``/``count_results``."""
        low, high = self.window(default_zone)
        return {"run_id": self.run, "vehicle": self.vehicle, "kind": self.kind,
                "since": low, "until": high}  # fmt: skip
