"""Result routes: stored estimation and calibration results, listed with filters a page at a
time, one result, the results of a run, several side by side, and a result's report (its
figures one by one, or report.md, figures and result.json as one zip).

``/results/compare`` is declared before ``/results/{result_id}`` so the word is never read
as an id.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Depends, HTTPException, Query
from fastapi.responses import Response

from api.core.job_model import without_report_files
from api.core.jobs import REPORT_SUFFIXES, JobRunner
from api.core.paging import ResultsPage
from api.core.report_archive import archive_name, report_zip
from api.core.result_compare import compare_results, parse_ids
from api.core.result_filter import ResultFilter
from api.core.result_subject import subject
from api.http.app_codes import app_router
from api.http.deps import RunnerDep, StoreDep, require_read
from api.http.schemas import ResultOut, error_responses, file_response
from daq.store import ResultNotFound, Store
from daq.store.run_records import ResultInfo

router = app_router("/api", "results")
_READ = error_responses(401, 404, 422)


def _result_json(result: ResultInfo, runner: JobRunner) -> dict:
    data = without_report_files(result.to_json())
    data["subject"] = subject(result.kind, result.data)
    data["report_plots"] = runner.report_names(result.id)
    return data


def _find_result(store: Store, result_id: int | str) -> ResultInfo:
    try:
        return store.result(result_id)
    except ResultNotFound as err:
        raise HTTPException(404, str(err)) from None


@router.get(
    "/runs/{run_id}/results",
    response_model=list[ResultOut],
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_run_results(run_id: str, store: StoreDep, runner: RunnerDep) -> list[dict]:
    """Estimation and calibration results made from this run, oldest first."""
    return [_result_json(r, runner) for r in store.results(store.get_run(run_id).id)]


@router.get(
    "/results",
    response_model=list[ResultOut],
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def list_results(
    store: StoreDep,
    runner: RunnerDep,
    response: Response,
    result_filter: Annotated[ResultFilter, Query()],
    page: Annotated[ResultsPage, Query()],
) -> list[dict]:
    """Estimation and calibration results, newest first, a page at a time (paged in the
    database): ``X-Total-Count`` says how many match, ``X-Next-Offset`` where the next page
    starts (absent on the last). An unknown ``run`` is a 404 naming it. The filters are
    ``api.core.result_filter.ResultFilter``'s, the page ``api.core.paging.ResultsPage``'s
    (``rig results`` too)."""
    filters, offset = result_filter.store_filters(), page.offset
    found = store.list_results(**filters, limit=page.limit, offset=offset)
    total = store.count_results(**filters)
    response.headers["X-Total-Count"] = str(total)
    if offset + len(found) < total:
        response.headers["X-Next-Offset"] = str(offset + len(found))
    return [_result_json(r, runner) for r in found]


@router.get("/results/compare", dependencies=[Depends(require_read)], responses=_READ)
def compare(
    store: StoreDep,
    ids: Annotated[str, Query(description="Two to twelve result ids: 12,13.")],
) -> dict[str, Any]:
    """Results side by side: per coefficient each one's value ± U (the budget's expanded
    uncertainty where present, else 2σ) and its difference from the first result in σ
    units, |a−b|/√(σa²+σb²). A malformed ``ids`` is a 422, an unknown id a 404 naming it."""
    return compare_results([_find_result(store, i) for i in parse_ids(ids)])


@router.get(
    "/results/{result_id}",
    response_model=ResultOut,
    dependencies=[Depends(require_read)],
    responses=_READ,
)
def get_result(result_id: int, store: StoreDep, runner: RunnerDep) -> dict:
    """One result (estimation JSON of issue 4, or a thrust calibration with its inverse map)."""
    return _result_json(_find_result(store, result_id), runner)


@router.get(
    "/results/{result_id}/report.zip",
    dependencies=[Depends(require_read)],
    responses=file_response({"application/zip": {}}, "The report as a zip") | _READ,
    response_class=Response,
)
def get_report_zip(result_id: int, store: StoreDep, runner: RunnerDep) -> Response:
    """The result's report to download: report.md, its figures (PNG and SVG) and
    result.json in one zip (a result stored before reports kept report.md has only the
    figures and result.json)."""
    document = _result_json(_find_result(store, result_id), runner)
    content = report_zip(document, runner.report_contents(result_id))
    disposition = f'attachment; filename="{archive_name(result_id)}"'
    return Response(
        content, media_type="application/zip", headers={"Content-Disposition": disposition}
    )


def _report_figure_route(suffix: str, function_name: str, doc: str) -> None:
    """``GET /api/results/{result_id}/report/{name}<suffix>``: a stored report figure (from
    the database, so it outlives the service) in the format ``suffix`` names."""

    def report_figure(result_id: int, name: str, store: StoreDep, runner: RunnerDep) -> Response:
        _find_result(store, result_id)
        found = runner.report_file(result_id, name, suffix)
        if found is None:
            raise HTTPException(404, f"result {result_id} has no report plot named {name!r}")
        media_type, content = found
        return Response(content, media_type=media_type)

    report_figure.__name__ = function_name  # the OpenAPI operation id
    report_figure.__doc__ = doc
    content: dict[str, dict[str, Any]] = {REPORT_SUFFIXES[suffix]: {}}
    router.get(
        f"/results/{{result_id}}/report/{{name}}{suffix}",
        dependencies=[Depends(require_read)],
        responses=file_response(content, "A report plot") | _READ,
        response_class=Response,
    )(report_figure)


_report_figure_route(
    ".png", "get_report_plot", "A report figure as a 150 dpi PNG (names in ``report_plots``)."
)
_report_figure_route(
    ".svg", "get_report_svg", "The same report figure as SVG (vector, its labels as text)."
)
