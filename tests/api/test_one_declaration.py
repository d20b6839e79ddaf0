"""An operation's parameters are declared once, on its request model (``Field``: the
range and the help; ``Flag``: the option): the route's query parameters and the command's
options are derived from it, so the two faces cannot drift apart in name, help or range."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner
from pydantic import BaseModel

from api.cli.command_table import COMMANDS, records_runs
from api.cli.main import main
from api.core.calibration_queries import CalibrationChoice, StandTableQuery, ThrustQuery
from api.core.campaign_request import CampaignRequest
from api.core.crosscheck_requests import CrossCheckJobRequest, CrossCheckRequest
from api.core.export_request import ExportQuery
from api.core.imports import ImportQuery
from api.core.job_filter import JobFilter
from api.core.paging import JobsPage, ResultsPage, RunsPage
from api.core.people import AckIn, HoldIn, ReleaseIn
from api.core.pretest import PretestQuery
from api.core.result_filter import ResultFilter
from api.core.run_filter import RunFilter
from api.core.run_metadata_query import RunMetadataQuery
from api.core.sensitivity_request import SensitivityRequest
from api.core.sequence_request import SequenceRequest
from api.core.theory import AddedMassQuery, WaterQuery
from daq.procedures.flag import Flag
from daq.procedures.run_kinds import import_fields
from tests.api.conftest import AUTH

#: The rig behind the service runs in process on simulated time (tests/api/conftest.py).
pytestmark = pytest.mark.simtime

#: (model, the route's method and path, the command) of each operation taking a query.
OPERATIONS = [
    (ImportQuery, "post", "/api/runs/import", "import"),
    (StandTableQuery, "post", "/api/calibrations/import", "import-calibration"),
    (ThrustQuery, "get", "/api/thrust", "thrust"),
    (RunFilter, "get", "/api/runs", "runs"),
    (ResultFilter, "get", "/api/results", "results"),
    (WaterQuery, "get", "/api/water", "water"),
    (AddedMassQuery, "get", "/api/vehicles/{name}/added-mass", "predict-added-mass"),
    (PretestQuery, "get", "/api/sequences/{name}/uncertainty", "predict-uncertainty"),
    (RunMetadataQuery, "post", "/api/runs/import", "import"),
    (ExportQuery, "get", "/api/runs/{run_id}/export", "export"),
    (CalibrationChoice, "get", "/api/thrust", "thrust"),
    (JobFilter, "get", "/api/jobs", "jobs"),
    (RunsPage, "get", "/api/runs", "runs"),
    (JobsPage, "get", "/api/jobs", "jobs"),
    (ResultsPage, "get", "/api/results", "results"),
]

#: (the route's method and path, the command, its models, what only one face takes: the
#: route's query parameters and the command's options that are no request field).
WHOLE = [
    (("post", "/api/runs/import"), "import", (ImportQuery, RunMetadataQuery, import_fields()),
     {"filename"}, {"rig_file", "db_url", "as_json"}),
    (("get", "/api/runs/{run_id}/export"), "export", (ExportQuery,), set(),
     {"output", "db_url"}),
    (("get", "/api/thrust"), "thrust", (ThrustQuery, CalibrationChoice), set(),
     {"db_url", "as_json"}),
    (("get", "/api/jobs"), "jobs", (JobFilter, JobsPage), set(), {"db_url", "as_json"}),
    (("get", "/api/runs"), "runs", (RunFilter, RunsPage), set(), {"db_url", "as_json"}),
    (("get", "/api/results"), "results", (ResultFilter, ResultsPage), set(),
     {"compare", "db_url", "as_json"}),
]  # fmt: skip


def _flags(model: type[BaseModel]) -> dict[str, tuple[Flag, str | None]]:
    return {
        name: (flag, info.description)
        for name, info in model.model_fields.items()
        for flag in info.metadata
        if isinstance(flag, Flag)
    }


#: (model, the route's method and path, the command) of operations taking a JSON body.
BODIES = [
    (CrossCheckRequest, "post", "/api/crosscheck", "crosscheck"),
    (CrossCheckJobRequest, "post", "/api/jobs/crosscheck", "crosscheck"),
    (SensitivityRequest, "post", "/api/analysis/sensitivity", "sensitivity"),
    (CampaignRequest, "post", "/api/campaigns", "campaign"),
    (SequenceRequest, "post", "/api/jobs/sequence", "sequence"),
    (AckIn, "post", "/api/estop/ack", "ack-estop"),
    (HoldIn, "post", "/api/rig/hold", "hold"),
    (ReleaseIn, "post", "/api/rig/release", "release"),
]


def _command(name: str) -> dict[str, click.Option]:
    with click.Context(main) as ctx:
        cmd = main.get_command(ctx, name)
    assert cmd is not None
    return {o.name: o for o in cmd.params if isinstance(o, click.Option) and o.name}


@pytest.mark.parametrize(("model", "method", "path", "command"), BODIES, ids=[b[2] for b in BODIES])
def test_route_body_and_command_take_each_field_of_the_model_with_its_help(
    client, model, method, path, command
):
    spec = client.get("/openapi.json").json()
    schema = spec["paths"][path][method]["requestBody"]["content"]["application/json"]["schema"]
    refs = [s["$ref"] for s in schema.get("anyOf", [schema]) if "$ref" in s]  # optional: anyOf
    assert [r.rsplit("/", 1)[-1] for r in refs] == [model.__name__]  # the body is the model
    options = _command(command)
    for name, (flag, description) in _flags(model).items():
        option = options[name]
        assert flag.name in option.opts, (name, option.opts)
        assert (option.help or "").startswith(flag.help or description or ""), name


@pytest.mark.parametrize(
    ("model", "method", "path", "command"), OPERATIONS, ids=[op[3] for op in OPERATIONS]
)
def test_route_and_command_take_each_field_of_the_model_with_its_help(
    client, model, method, path, command
):
    parameters = {
        p["name"]: p
        for p in client.get("/openapi.json").json()["paths"][path][method]["parameters"]
        if p["in"] == "query"
    }
    options = _command(command)
    fields = _flags(model)
    assert fields, f"{model.__name__} declares no option"
    for name, (flag, description) in fields.items():
        assert name in parameters, f"{path} has no query parameter {name}"
        assert parameters[name].get("description") == description, name
        option = options[name]
        assert flag.name in option.opts, (name, option.opts)
        assert (option.help or "").startswith(flag.help or description or ""), name


@pytest.mark.parametrize(("route", "command", "models", "route_only", "command_only"), WHOLE,
                         ids=[w[1] for w in WHOLE])  # fmt: skip
def test_no_parameter_of_the_route_or_option_of_the_command_is_declared_beside_its_models(
    client, route, command, models, route_only, command_only
):
    """A query parameter or an option written by hand next to the model is a second
    declaration that can drift: every one is a model's field, or says why it is one face's."""
    method, path = route
    spec = client.get("/openapi.json").json()["paths"][path][method]["parameters"]
    declared = {name for model in models for name in model.model_fields}
    assert {p["name"] for p in spec if p["in"] == "query"} - declared == route_only
    flagged = {name for model in models for name in _flags(model)}
    assert set(_command(command)) - flagged == command_only


#: Every command that records or imports runs, and the one that annotates them afterwards.
RECORDING = [name for name, (module, _) in COMMANDS.items() if records_runs(name, module)]


@pytest.mark.parametrize("command", [*RECORDING, "annotate"])
def test_each_command_recording_runs_takes_the_run_metadata_options_of_the_model(command):
    options = _command(command)
    for name, (flag, description) in _flags(RunMetadataQuery).items():
        assert flag.name in options[name].opts, (command, name)
        assert (options[name].help or "").startswith(flag.help or description or ""), name


@pytest.mark.parametrize(
    ("page", "path", "command"),
    [(RunsPage, "/api/runs", "runs"), (JobsPage, "/api/jobs", "jobs"),
     (ResultsPage, "/api/results", "results")],
)  # fmt: skip
def test_a_page_past_its_list_s_size_is_refused_alike_by_the_route_and_the_command(
    client, page, path, command, tmp_path
):
    """One range per list (``api.core.paging``): the command had taken 10 000 jobs where
    the route took 500, and 50 rows by default where the route gave 100."""
    most = page.model_json_schema()["properties"]["limit"]["maximum"]
    assert client.get(f"{path}?limit={most}", headers=AUTH).status_code == 200
    r = client.get(f"{path}?limit={most + 1}", headers=AUTH)
    assert r.status_code == 422 and "limit" in r.text, r.text
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    said = CliRunner().invoke(main, [command, "--db", db, "--limit", str(most + 1)])
    assert said.exit_code == 2
    assert f"'--limit': {most + 1} is not in the range 1<=x<={most}" in said.output
    assert _command(command)["limit"].default == page.model_fields["limit"].default


@pytest.mark.parametrize(
    ("query", "argv"),
    [
        ("force_n=1&calibration=x:1", ["thrust", "--force", "1", "--calibration", "x:1"]),
        ("force_n=1&calibration=run:0", ["thrust", "--force", "1", "--calibration", "run:0"]),
    ],
)
def test_a_bad_calibration_is_refused_alike_by_the_route_and_the_command(client, query, argv):
    r = client.get(f"/api/thrust?{query}", headers=AUTH)
    assert r.status_code == 422, r.text
    said = CliRunner().invoke(main, argv)
    assert said.exit_code == 2
    assert said.output.strip() == f"error: --{r.json()['detail']}"
    assert "is not allowed (ID or run:ID" in r.json()["detail"]


def test_a_bad_hold_reason_is_refused_alike_by_the_route_and_the_command(client):
    """One rule (``check_reason``) on the model both faces validate: the route's 422 and the
    command's line say the same (the route had said pydantic's words for an empty one)."""
    r = client.post("/api/rig/hold", json={"reason": " "}, headers=AUTH)
    assert r.status_code == 422, r.text
    assert r.json()["detail"].startswith("reason: ' ' is not allowed (allowed 1-200 characters")
    said = CliRunner().invoke(main, ["hold", "--user", "default", "--reason", " "])
    assert said.exit_code == 2
    assert said.output.strip() == f"error: --{r.json()['detail']}"


def test_a_sequence_rest_out_of_range_is_refused_by_the_route_and_the_command(client):
    """The body's ``rest_s`` is refused in a sequence file's words; ``rig sequence --rest``
    takes the same range from the same field."""
    body = {"rest_s": 3601, "steps": [{"kind": "tow", "force_n": 4.9}]}
    r = client.post("/api/jobs/sequence", json=body, headers=AUTH)
    assert r.status_code == 422, r.text
    assert r.json()["detail"] == "rest_s: 3601 is not allowed (allowed 0 ≤ rest_s ≤ 3600 s)"
    said = CliRunner().invoke(main, ["sequence", "any.toml", "--rest", "3601"])
    assert said.exit_code == 2
    assert "'--rest': 3601.0 is not in the range 0<=x<=3600" in said.output
