"""An estimation that failed in its numerics, told apart from bad input at every face.

Bad input (an unknown run, a run without its drive, too few samples after the release) is
found before anything is fitted and names the field: the CLI exits 2, the API answers 422.
What fails after that — an overflow in a simulation, NaN in a Jacobian, a singular matrix —
is ours, not the user's: :func:`fitting` turns it into :class:`EstimationFailure`, one line
``could not fit <what>: <why>``; the CLI exits 1 and an estimation job ends ``failed``. A
method that does not suit the prepared records (``estimation.errors.MethodRefused``) is
the user's and passes through as it is.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np

from estimation.errors import EstimationFailed, MethodRefused

#: What the numerics raise when a fit breaks down on valid input: numpy with ``np.seterr``
#: raising (FloatingPointError), scipy's "array must not contain infs or NaNs" (ValueError),
#: a singular matrix (LinAlgError), an overflow or a division by zero (ArithmeticError),
#: ``curve_fit``'s "Optimal parameters not found" (RuntimeError). The estimator's own
#: ``EstimationFailed`` already says what could not be fitted: it is passed on as it is.
NUMERIC_FAILURES: tuple[type[Exception], ...] = (
    FloatingPointError,
    ArithmeticError,
    ValueError,
    np.linalg.LinAlgError,
    RuntimeError,
)


class EstimationFailure(RuntimeError):
    """A fit that could not be done on input that was checked and valid: ours, not the
    user's. The message is one line, ``could not fit <what>: <why>``."""


def fit_subject(axis: str, run_ids: Sequence[str]) -> str:
    """What is fitted, for the failure line: ``surge of run 3f2a9c1b`` or ``yaw of runs
    3f2a9c1b, 77aa0e12``."""
    shown = ", ".join(rid[:8] for rid in run_ids)
    return f"{axis} of run{'s' if len(run_ids) > 1 else ''} {shown}"


@contextmanager
def fitting(subject: str, doing: str = "fit") -> Iterator[None]:
    """Run a fit (or, with ``doing="draw the report of"``, its report): a numerical failure
    inside becomes :class:`EstimationFailure` ``could not <doing> <subject>: <why>``, chained
    to the original (its traceback shows with ``RIG_DEBUG=1`` and in the service log).

    numpy's floating-point errors inside (overflow, invalid value, division by zero) are
    noted instead of printed as warnings (numpy's error state is per context, so other
    threads are untouched) and named in the line, as the first sign of what went wrong:
    ``array must not contain infs or NaNs (after overflow, invalid value in the numerics)``."""
    seen: list[str] = []

    def note(kind: str, flag: int) -> None:
        if kind not in seen:
            seen.append(kind)

    try:
        with np.errstate(call=note, over="call", invalid="call", divide="call"):
            yield
    except EstimationFailure:
        raise
    except MethodRefused:  # the method does not suit the records: the user's, as it is
        raise
    except EstimationFailed as err:  # the estimator's own line: "could not fit …: why"
        raise EstimationFailure(str(err)) from err
    except NUMERIC_FAILURES as err:
        why = " ".join(str(err).split()) or type(err).__name__
        if seen:
            why += f" (after {', '.join(seen)} in the numerics)"
        raise EstimationFailure(f"could not {doing} {subject}: {why}") from err
