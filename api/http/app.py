"""The FastAPI application: routes, error bodies, token checks, the browser UI.

``create_app(service, token=...)`` wires a ``RigService`` (the rig thread) and a
``JobRunner`` into the routes. With ``manage_service`` (the default) the app's
lifespan starts the rig when the server starts and leaves it safe when it stops.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import AsyncIterator, Sequence
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.middleware.cors import CORSMiddleware
from fastapi.middleware.trustedhost import TrustedHostMiddleware
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.exceptions import HTTPException as StarletteHTTPException

from api.core.jobs import JobConflict, JobNotFound, JobRunner
from api.core.rig_guard import RigHeld
from api.core.service import RigService, RigUnavailable
from api.http.known_warnings import ignore_known_warnings
from api.http.limits import JSON_BODY_LIMIT, UPLOAD_BODY_LIMIT, BodyLimit
from api.http.request_errors import request_json_error, request_not_found
from api.http.routes import analysis as routes_analysis
from api.http.routes import calibration as routes_calibration
from api.http.routes import campaigns as routes_campaigns
from api.http.routes import crosscheck as routes_crosscheck
from api.http.routes import imports as routes_imports
from api.http.routes import jobs as routes_jobs
from api.http.routes import kinds as routes_kinds
from api.http.routes import people as routes_people
from api.http.routes import queue as routes_queue
from api.http.routes import results as routes_results
from api.http.routes import rig as routes_rig
from api.http.routes import runs as routes_runs
from api.http.routes import sequences as routes_sequences
from api.http.routes import sixdof as routes_sixdof
from api.http.routes import stream as routes_stream
from api.http.routes import theory as routes_theory
from api.http.routes import users as routes_users
from api.http.security import SecurityHeaders, TokenFirst
from api.http.static_assets import app_with_offline_docs, bundle, compress_static
from daq.procedures.kind_spec import NotCapable
from daq.procedures.params import ParameterError
from daq.store import AmbiguousRunId, RunNotFound
from daq.store.database import software_version
from daq.store.faults import StorageUnavailable
from thrusters.status import ThrusterError

log = logging.getLogger(__name__)
STATIC_DIR = Path(__file__).parent / "static"
#: plotly.js's basic bundle (scatter, bar, pie: every trace the UI draws), vendored from npm
#: ``plotly.js-basic-dist-min`` 4.1.1 (MIT, ``vendor/LICENSE-plotly.js.txt``): 1.2 MB where the full
#: bundle the ``plotly`` Python package ships is 4.8 MB, which a browser compiled in ~1 s of a
#: core on every page that drew a plot.
PLOTLY_JS = STATIC_DIR / "vendor" / "plotly-basic.min.js"
#: Largest CSV upload accepted (bytes).
MAX_UPLOAD_BYTES = UPLOAD_BODY_LIMIT
#: Host names an ``open_read`` service always answers to (besides ``allowed_hosts``).
LOCAL_HOSTS = ("localhost", "127.0.0.1", "::1", "[::1]")

ignore_known_warnings()  # pydantic's false positive at the first list requests


def _json_safe(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    try:
        json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):
        return str(value)
    return value


def _error(status: int, detail: str, **extra: Any) -> JSONResponse:
    body = {"detail": detail} | {k: v for k, v in extra.items() if v is not None}
    return JSONResponse(body, status_code=status)


def _install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(StarletteHTTPException)
    async def http_error(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        response = _error(exc.status_code, str(exc.detail))
        for k, v in (exc.headers or {}).items():
            response.headers[k] = v
        return response

    @app.exception_handler(RequestValidationError)
    async def validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
        not_found = request_not_found(exc.errors())
        if not_found is not None:  # an id no resource can have is an unknown id
            return _error(404, not_found)
        invalid_json = request_json_error(exc.errors())
        if invalid_json is not None:
            return _error(422, invalid_json["message"], errors=[invalid_json])
        problems = []
        for e in exc.errors():
            raised = (e.get("ctx") or {}).get("error")
            if isinstance(raised, ParameterError):  # a model's validator named its fields
                problems += raised.to_json()
                continue
            loc = [str(p) for p in e.get("loc", ()) if p not in ("body", "query", "path")]
            field = ".".join(loc) or "body"
            value = None if e.get("type") == "missing" else _json_safe(e.get("input"))
            problems.append(
                {
                    "field": field,
                    "value": value,
                    "allowed": e.get("msg", "invalid"),
                    "message": f"{field}: {value!r} is not allowed; {e.get('msg', 'invalid')}",
                }
            )
        detail = "; ".join(p["message"] for p in problems) or "invalid request"
        return _error(422, detail, errors=problems)

    @app.exception_handler(ParameterError)
    async def parameter_error(request: Request, exc: ParameterError) -> JSONResponse:
        return _error(422, str(exc), errors=exc.to_json())

    @app.exception_handler(NotCapable)
    async def not_capable(request: Request, exc: NotCapable) -> JSONResponse:
        # The request is well formed; the rig (its rig file) cannot do it.
        return _error(409, str(exc), errors=exc.to_json())

    @app.exception_handler(RunNotFound)
    async def run_not_found(request: Request, exc: RunNotFound) -> JSONResponse:
        return _error(404, str(exc))

    @app.exception_handler(JobNotFound)
    async def job_not_found(request: Request, exc: JobNotFound) -> JSONResponse:
        return _error(404, str(exc))

    @app.exception_handler(AmbiguousRunId)
    async def ambiguous(request: Request, exc: AmbiguousRunId) -> JSONResponse:
        return _error(404, str(exc))

    @app.exception_handler(JobConflict)
    async def conflict(request: Request, exc: JobConflict) -> JSONResponse:
        return _error(423 if isinstance(exc, RigHeld) else 409, str(exc), holder=exc.holder)

    @app.exception_handler(RigUnavailable)
    async def unavailable(request: Request, exc: RigUnavailable) -> JSONResponse:
        return _error(503, str(exc))

    @app.exception_handler(StorageUnavailable)
    async def storage_unavailable(request: Request, exc: StorageUnavailable) -> JSONResponse:
        # Any route: the database down, full or read-only is the service unavailable, said
        # in one line naming the database (no traceback, no SQL, no password, no host path).
        log.warning("%s %s: %s", request.method, request.url.path, exc)
        return _error(503, str(exc))

    @app.exception_handler(ValueError)
    async def bad_value(request: Request, exc: ValueError) -> JSONResponse:
        # The store and the CSV import name the field (or line/column) in their message.
        if "JSON compliant" in str(exc):  # our bug (a NaN in a response), not bad input
            log.error("response not JSON-serialisable: %s", exc)
            return _error(500, "internal error: a response held a non-finite number")
        return _error(422, str(exc))

    @app.exception_handler(TimeoutError)
    async def timeout(request: Request, exc: TimeoutError) -> JSONResponse:
        return _error(503, f"the rig did not answer in time: {exc}")

    @app.exception_handler(ThrusterError)
    async def thrusters_refused(request: Request, exc: ThrusterError) -> JSONResponse:
        # The controller refused or did not answer (arm, disarm): the rig cannot do it now,
        # said in one line naming the controller; the driver left the outputs at zero.
        log.warning("%s %s: %s", request.method, request.url.path, exc)
        return _error(503, f"thrusters: {exc}")


def create_app(
    service: RigService,
    *,
    token: str,
    open_read: bool = False,
    cors_origins: Sequence[str] = (),
    allowed_hosts: Sequence[str] = (),
    max_upload_bytes: int = MAX_UPLOAD_BYTES,
    max_json_bytes: int = JSON_BODY_LIMIT,
    manage_service: bool = True,
    report_root: Path | None = None,
    runner: JobRunner | None = None,
) -> FastAPI:
    """The rig's HTTP API and browser UI on top of ``service`` (and an existing ``runner``,
    to serve the same jobs from a second app).

    Request bodies are capped before parsing and before the token check (``api.http.limits``);
    a state-changing request's token is checked before its body is read, and every answer
    carries a Content-Security-Policy with ``frame-ancestors 'none'`` (``api.http.security``).
    With ``open_read`` only requests whose ``Host`` is local or in ``allowed_hosts`` are
    answered (400 otherwise), so a DNS-rebinding page cannot read runs or the stream."""
    own_runner = runner is None
    runner = runner or JobRunner(service, report_root=report_root)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        import asyncio

        if manage_service and not service.started:  # `rig serve` starts it beforehand
            await asyncio.to_thread(service.start)
        if own_runner and service.started:
            await asyncio.to_thread(runner.open)  # interrupted jobs, the queue (paused)
        try:
            yield
        finally:
            if own_runner:
                runner.close()
            if manage_service:
                await asyncio.to_thread(service.stop)

    app = app_with_offline_docs(
        title="towrig rig service",
        version=software_version(),
        description="Run the underwater-vehicle test rig: tests as jobs, stored runs, "
        "estimation, a live stream. Every state-changing endpoint needs "
        "`Authorization: Bearer <token>` (`rig token` prints it); read-only ones too "
        "unless the service runs with `--open-read`.",
        lifespan=lifespan,
    )
    app.state.service = service
    app.state.runner = runner
    app.state.token = token
    app.state.open_read = open_read
    app.state.max_upload_bytes = max_upload_bytes
    _install_error_handlers(app)
    compress_static(app)
    app.add_middleware(TokenFirst)  # inside CORS: a refusal still carries its headers
    if cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=list(cors_origins),
            allow_methods=["GET", "POST"],
            allow_headers=["Authorization", "Content-Type"],
        )
    if open_read:
        app.add_middleware(
            TrustedHostMiddleware,
            allowed_hosts=[*LOCAL_HOSTS, *allowed_hosts],
            www_redirect=False,
        )
    app.add_middleware(BodyLimit, json_limit=max_json_bytes, upload_limit=max_upload_bytes)
    app.add_middleware(SecurityHeaders)  # outermost: on every answer, 413s included
    for module in (
        routes_rig,
        routes_kinds,
        routes_crosscheck,
        routes_jobs,
        routes_people,
        routes_queue,
        routes_campaigns,
        routes_users,
        routes_sequences,
        routes_runs,
        routes_results,
        routes_imports,
        routes_stream,
        routes_sixdof,
        routes_analysis,
        routes_calibration,
        routes_theory,
    ):
        app.router.routes.extend(module.router.routes)

    @app.get("/", include_in_schema=False)
    def index() -> FileResponse:
        return FileResponse(STATIC_DIR / "index.html", media_type="text/html")

    @app.get(f"/static/{PLOTLY_JS.relative_to(STATIC_DIR)}", include_in_schema=False)
    def plotly_bundle(request: Request) -> Response:
        return bundle(PLOTLY_JS, "text/javascript", request.headers.get("accept-encoding", ""))

    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    return app
