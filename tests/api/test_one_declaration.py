"""An operation's parameters are declared once, on its request model (``Field``: the
range and the help; ``Flag``: the option): the route's query parameters and the command's
options are derived from it, so the two faces cannot drift apart in name, help or range."""

from __future__ import annotations

import click
import pytest
from pydantic import BaseModel

from api.cli.main import main
from api.core.calibration_queries import StandTableQuery, ThrustQuery
from api.core.campaign_request import CampaignRequest
from api.core.crosscheck_requests import CrossCheckJobRequest, CrossCheckRequest
from api.core.imports import ImportQuery
from api.core.pretest import PretestQuery
from api.core.result_filter import ResultFilter
from api.core.run_filter import RunFilter
from api.core.sensitivity_request import SensitivityRequest
from api.core.theory import AddedMassQuery, WaterQuery
from daq.procedures.flag import Flag

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
]


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
    ref = spec["paths"][path][method]["requestBody"]["content"]["application/json"]["schema"]
    assert ref["$ref"].rsplit("/", 1)[-1] == model.__name__  # the body is the model itself
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
