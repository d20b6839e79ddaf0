"""``rig results``: stored estimation and calibration results, newest first, or two or more
side by side (``--compare``), as ``GET /api/results`` and ``GET /api/results/compare``."""

from __future__ import annotations

from datetime import datetime

import click

from api.cli.command_table import rig_command
from api.cli.common import (
    db_option,
    echo_json,
    fail,
    flag_names,
    json_option,
    open_store,
    user_errors,
)
from api.cli.options import request_from, request_options
from api.core.paging import ResultsPage
from api.core.result_filter import ResultFilter
from api.core.result_subject import subject


def _pm(cell: dict | None) -> str:
    if cell is None or cell["value"] is None:
        return "—"
    u = "—" if cell["U"] is None else f"{cell['U']:.3g}"
    return f"{cell['value']:.5g} ± {u} ({cell['U_from']})"


@rig_command()
@request_options(ResultFilter)
@request_options(ResultsPage)
@click.option(
    "--compare",
    is_flag=True,
    help="Compare the results IDS (rig results --compare 12 13): value ± U per coefficient "
    "and the difference from the first in σ.",
)
@click.argument("compare_ids", metavar="[IDS]...", nargs=-1, type=click.IntRange(1))
@db_option
@json_option
def results(compare, compare_ids, db_url, as_json, **chosen):
    """List stored results, newest first, or compare two or more (--compare)."""
    from api.core.result_compare import MAX_COMPARED, MIN_COMPARED, compare_results

    if compare_ids and not compare:
        fail(
            f"IDS: {list(compare_ids)} is not allowed without --compare "
            "(rig results --compare 12 13)"
        )
    store = open_store(db_url)
    try:
        if compare:
            if not MIN_COMPARED <= len(set(compare_ids)) == len(compare_ids) <= MAX_COMPARED:
                fail(f"--compare: {list(compare_ids)} is not allowed; give {MIN_COMPARED} … "
                     f"{MAX_COMPARED} distinct result ids")  # fmt: skip
            with user_errors():
                doc = compare_results([store.result(i) for i in compare_ids])
            if as_json:
                return echo_json(doc)
            ids = [r["id"] for r in doc["results"]]
            click.echo("coefficient".ljust(24) + "".join(f"#{i} value ± U".ljust(34) for i in ids)
                       + "".join(f"#{i}−#{ids[0]} (σ)".ljust(14) for i in ids[1:]))  # fmt: skip
            for row in doc["coefficients"]:
                diffs = ["—" if d is None else f"{d:.3g}" for d in row["difference_sigma"][1:]]
                cells = "".join(_pm(c).ljust(34) for c in row["cells"])
                click.echo(
                    row["coefficient"].ljust(24) + cells + "".join(d.ljust(14) for d in diffs)
                )
            return None
        # the filters as GET /api/results takes them (api.core.result_filter), days local
        result_filter = request_from(ResultFilter, chosen)
        page = request_from(ResultsPage, chosen)
        with user_errors():
            try:
                filters = result_filter.store_filters(datetime.now().astimezone().tzinfo)
                found = store.list_results(**filters, limit=page.limit, offset=page.offset)
            except ValueError as err:  # a day, a date-time or a zone none of the forms
                fail(flag_names(click.get_current_context(), str(err)))
        if as_json:
            return echo_json([r.to_json() | {"subject": subject(r.kind, r.data)} for r in found])
        for r in found:
            what = subject(r.kind, r.data)
            runs = " ".join(i[:8] for i in r.run_ids)
            click.echo(f"#{r.id:<5} {r.kind:<12} {r.created_at:%Y-%m-%d %H:%M}  {what:<32} {runs}")
        return None
    finally:
        store.close()
