"""The error codes the app answers on a route's behalf, declared on that route.

A route's own ``responses=`` names what its handler refuses (404 unknown id, 409 wrong
state, …). Some codes follow from what the route depends on instead, and are declared here
from its dependencies and its body, once for every route, so that the OpenAPI document (and
docs/api.md) says every code a route can answer (``tests/api/test_status_codes.py``):

- 401: the token (``require_read``, ``require_write``);
- 403: a viewer's token where an operator's is needed (``require_write``);
- 413: a request body over the route's cap (``api.http.limits.BodyLimit``);
- 503: the run database is not open (``get_store``: the service not started or stopped),
  or it cannot be reached or written (``daq.store.faults.StorageUnavailable``); a route
  that reads the database without ``get_store`` declares its 503 itself.

Every route module's router makes :class:`AppCodesRoute` routes, so a route is complete
where it is declared and every app serves the same route objects (``api.http.app``).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

from fastapi import APIRouter
from fastapi.dependencies.models import Dependant
from fastapi.routing import APIRoute

from api.http.deps import get_store, require_read, require_write
from api.http.schemas import error_responses

#: Codes a dependency adds to every route that uses it.
BY_DEPENDENCY: dict[Callable[..., Any], tuple[int, ...]] = {
    require_read: (401,),
    require_write: (401, 403),
    get_store: (503,),
}
#: Codes a route with a request body gets (the body-size cap).
WITH_BODY = (413,)


def _calls(dependant: Dependant) -> Iterator[Callable[..., Any]]:
    for dependency in dependant.dependencies:
        if dependency.call is not None:
            yield dependency.call
        yield from _calls(dependency)


def app_codes(route: APIRoute) -> set[int]:
    """The codes the app answers on ``route``'s behalf (module docstring)."""
    codes = {c for call in _calls(route.dependant) for c in BY_DEPENDENCY.get(call, ())}
    has_body = route.body_field is not None or "requestBody" in (route.openapi_extra or {})
    if has_body:
        codes.update(WITH_BODY)
    return codes


class AppCodesRoute(APIRoute):
    """A route whose ``responses`` include the codes the app answers on its behalf
    (:func:`app_codes`), and so its OpenAPI document. A route's response models are made as
    it is built, and the codes follow from its dependencies, known only once it is built: a
    route that lacks some is built again with them, once per process, where it is declared."""

    def __init__(self, path: str, endpoint: Callable[..., Any], **options: Any) -> None:
        super().__init__(path, endpoint, **options)
        missing = sorted(c for c in app_codes(self) if c not in self.responses)
        if missing:
            responses = {**self.responses, **error_responses(*missing)}
            super().__init__(path, endpoint, **(options | {"responses": responses}))


def app_router(prefix: str, tag: str) -> APIRouter:
    """A route module's router: ``prefix`` before its paths, ``tag`` in the OpenAPI
    document, :class:`AppCodesRoute` routes."""
    return APIRouter(prefix=prefix, tags=[tag], route_class=AppCodesRoute)
