"""What ``rig export`` and ``GET /api/runs/{id}/export`` take besides the run
(:class:`ExportQuery`), each parameter declared once (range, help, option). The formats are
``daq.export_formats``'s table."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

from daq.export_formats import FormatName, formats_help
from daq.procedures.flag import Flag


class ExportQuery(BaseModel):
    """How to write one run to a file."""

    model_config = ConfigDict(frozen=True)

    format: Annotated[
        FormatName,
        Field(description=formats_help() + "."),
        Flag("--format"),
    ] = "csv"
