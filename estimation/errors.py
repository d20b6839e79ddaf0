"""The estimator's exceptions: a numerical failure that is not the user's input, and a
quantity that describes nothing physical (the user's)."""

from __future__ import annotations

import math


class EstimationFailed(RuntimeError):
    """An estimate that could not be computed: names what and why, in one line.

    Not a ``ValueError``: the input was valid, the numerics failed (a simulation that
    diverged from every start, a fit whose residual stayed non-finite). The faces print
    ``str(err)`` as one line; ``what`` and ``why`` are the parts.
    """

    def __init__(self, what: str, why: str) -> None:
        super().__init__(f"could not fit {what}: {why}")
        self.what = what
        self.why = why

    def __reduce__(self) -> tuple[type, tuple[str, str]]:  # crosses to a worker and back
        return type(self), (self.what, self.why)


class MethodRefused(ValueError):
    """The method asked for does not suit these records, which shows only once they are
    prepared (a drive that reverses after its release, one drive level for a curve method):
    the user's choice of method, in one line naming the run, what it has and what would
    suit — bad input at every face (the CLI exits 2, a job ends ``failed`` unlogged), never
    a numerical failure."""


class FieldError(ValueError):
    """A quantity that describes nothing physical: one line naming the field, the value
    and what is allowed."""

    def __init__(self, field_name: str, value: object, allowed: str) -> None:
        self.field, self.value, self.allowed = field_name, value, allowed
        super().__init__(f"{field_name}: got {value!r}, allowed: {allowed}")

    def __reduce__(self) -> tuple[type, tuple[str, object, str]]:  # crosses processes
        return type(self), (self.field, self.value, self.allowed)


def positive(field_name: str, value: float, error: type[FieldError] = FieldError) -> float:
    """``value`` as a float when it is a finite number > 0, else ``error`` naming it."""
    if (
        not isinstance(value, (int, float))
        or isinstance(value, bool)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise error(field_name, value, "a finite number > 0")
    return float(value)
