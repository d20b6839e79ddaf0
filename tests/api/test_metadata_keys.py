"""A known run-metadata key is declared once (``daq.store.run_metadata.KNOWN``): one more
entry there reaches the store's check, the JSON ``metadata`` object, the import query and
the commands' options, the pages' inputs (made from the object's schema) and the docs'
table, each with its range, unit and help."""

from __future__ import annotations

import click
import pytest
from click.testing import CliRunner
from pydantic import ValidationError

from api.cli.docs_tables import parameter_table
from api.cli.options import model_options
from api.core.run_metadata_query import RunMetadataQuery, run_metadata_query_model
from daq.procedures.flag import Flag
from daq.procedures.procedure_request import RunMetadataIn, run_metadata_model
from daq.store import run_metadata
from daq.store.run_metadata import MetadataKey, check_run_metadata, is_free_key

#: The key a lab adds: one entry in the table, nothing else.
DEPTH = MetadataKey(
    "depth_m", "Depth of the vehicle's centre", "--depth", "M", number_range=(0.0, 10.0), unit="m"
)


@pytest.fixture
def depth_declared(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(run_metadata, "KNOWN", (*run_metadata.KNOWN, DEPTH))


@pytest.mark.usefixtures("depth_declared")
def test_a_key_added_to_the_table_reaches_the_store_both_models_the_options_and_the_docs():
    # the store: checked with its range and unit, no longer a free key
    assert check_run_metadata({"depth_m": 1}) == {"depth_m": 1.0}
    refused = r"^metadata\.depth_m: 12 is not allowed; use 0 ≤ depth_m ≤ 10 m$"
    with pytest.raises(ValueError, match=refused):
        check_run_metadata({"depth_m": 12})
    assert not is_free_key("depth_m") and is_free_key("ballast")

    # the JSON object: the schema says the range and the help; the store's check says no
    body = run_metadata_model()
    schema = body.model_json_schema()["properties"]["depth_m"]
    assert schema["description"] == "Depth of the vehicle's centre, m."
    # … and the label and unit the pages make its input with (api/http/static/run_metadata.js)
    assert (schema["title"], schema["unit"]) == ("Depth of the vehicle's centre (m)", "m")
    assert {"type": "number", "minimum": 0.0, "maximum": 10.0} in schema["anyOf"]
    assert body.model_validate({"depth_m": 1.5}).model_dump(exclude_unset=True) == {"depth_m": 1.5}

    # the query and the options: the model checks the range, the option is --depth
    query = run_metadata_query_model()
    assert query(depth_m=2.5, tag=["fins-v2"]).metadata() == {"depth_m": 2.5, "tags": ["fins-v2"]}
    with pytest.raises(ValidationError, match="less than or equal to 10"):
        query(depth_m=12)
    command = click.Command("record", params=model_options(query), callback=lambda **_: None)
    said = CliRunner().invoke(command, ["--depth", "12"])
    assert said.exit_code == 2 and "--depth" in said.output and "0<=x<=10" in said.output
    assert "--depth M" in CliRunner().invoke(command, ["--help"]).output

    # the docs' table row
    row = "| `depth_m` | `--depth` | number ≥ 0, ≤ 10 | — | Depth of the vehicle's centre, m. |"
    assert row in parameter_table(query).splitlines()
    assert row in parameter_table(body).splitlines()


@pytest.mark.parametrize("key", run_metadata.KNOWN, ids=lambda k: k.name)
def test_the_served_models_take_each_known_key_from_the_table(key: MetadataKey):
    for model in (RunMetadataIn, RunMetadataQuery):
        field = model.model_fields[key.name]
        assert field.description == key.description, model.__name__
        flag = next(m for m in field.metadata if isinstance(m, Flag))
        assert (flag.name, flag.metavar) == (key.option, key.metavar)
    body_schema = RunMetadataIn.model_json_schema()["properties"][key.name]["anyOf"][0]
    query_schema = RunMetadataQuery.model_json_schema()["properties"][key.name]["anyOf"][0]
    assert body_schema == query_schema  # the same range or length in both faces
