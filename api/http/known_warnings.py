"""Library warnings the service ignores: each a false positive, matched narrowly, with why.

A query-parameter model (``Annotated[RunFilter, Query()]``) reaches pydantic as
``Annotated[RunFilter, Field(alias="run_filter")]``. FastAPI silences pydantic's warning that
such an alias "has no effect" while it builds the field's adapter, but the list models defer
their build (``api.core.paging``, for the CLI's start-up), so the adapter is built at the
first request, outside FastAPI's silence, and ``rig serve`` printed one warning per model to
the technician's terminal. FastAPI reads the model's fields by their own names, so the
warning is pydantic's false positive (pydantic#12356).
"""

from __future__ import annotations

import warnings

from pydantic.warnings import UnsupportedFieldAttributeWarning

#: The start of that warning's message (a regular expression).
QUERY_MODEL_ALIAS = (
    r"The 'alias' attribute with value '\w+' was provided to the `Field\(\)` function"
)
_CATEGORY = UnsupportedFieldAttributeWarning

#: The same filter as a line of pytest's ``filterwarnings`` (pytest restores the filters after
#: each test, dropping the one the app installs when a test first imports it).
PYTEST_FILTER = f"ignore:{QUERY_MODEL_ALIAS}:{_CATEGORY.__module__}.{_CATEGORY.__qualname__}"


def ignore_known_warnings() -> None:
    """Install the filters (``api.http.app`` does when it is imported)."""
    warnings.filterwarnings("ignore", message=QUERY_MODEL_ALIAS, category=_CATEGORY)
