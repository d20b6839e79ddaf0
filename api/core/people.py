"""What acknowledging an emergency stop, holding the rig and releasing it take: one
declaration for the bodies of ``POST /api/estop/ack``, ``/api/rig/hold`` and
``/api/rig/release`` and the options of ``rig ack-estop``, ``rig hold`` and ``rig release``
(``request_options``), so the two faces cannot differ in name, length or help. Who acts is
each face's own: the request's token, the command's ``--user``."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, field_validator

from api.core.rig_guard import MAX_REASON, check_reason
from daq.procedures.flag import Flag


class _Body(BaseModel):
    model_config = ConfigDict(extra="forbid")


class AckIn(_Body):
    """Acknowledging an emergency stop."""

    note: Annotated[
        str,
        Field(
            max_length=MAX_REASON,
            description="What was checked before motion is allowed again (optional).",
        ),
        Flag("--note", metavar="TEXT"),
    ] = ""


class HoldIn(_Body):
    """Holding the rig for local work."""

    reason: Annotated[
        str,
        Field(min_length=1, max_length=MAX_REASON, description="Why, e.g. 'rigging the vehicle'."),
        Flag("--reason", metavar="TEXT"),
    ]

    @field_validator("reason", mode="before")
    @classmethod
    def _reason(cls, value: Any) -> str:
        """1 to ``MAX_REASON`` characters, not only blanks (``check_reason``'s words)."""
        return check_reason(value)


class ReleaseIn(_Body):
    """Releasing the hold."""

    override: Annotated[
        bool,
        Field(description="Release another operator's hold (logged as an override)."),
        Flag("--override", when_set=True),
    ] = False
