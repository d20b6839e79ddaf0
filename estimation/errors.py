"""The one exception for a numerical failure that is not the user's input."""

from __future__ import annotations


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
