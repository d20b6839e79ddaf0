"""How a request field is spelled on the command line (:class:`Flag`).

Light on purpose (no pydantic, no request models): a list's filters (``rig runs``) declare
their options with it without importing the procedures' request machinery
(``daq.procedures.procedure_request``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Flag:
    """How a request field is spelled on the command line.

    ``when_set``: the option is an on/off flag giving the field this value when present
    (``--thrusters`` → ``drive="thrusters"``); ``help`` then says what the flag does.
    ``parse`` turns the typed text into the field's value (``--commands 0,0.2`` → a list)."""

    name: str
    when_set: Any = None
    help: str | None = None
    metavar: str | None = None
    parse: Callable[[str], Any] | None = None
