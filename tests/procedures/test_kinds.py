"""The registry of run kinds: every kind reaches every face (API route, CLI command,
sequence step, job), and the CLI options are derived from the kind's request model."""

from __future__ import annotations

import json
from typing import Annotated

import click
import pytest
from click.testing import CliRunner
from pydantic import BaseModel, Field

from api.cli.main import COMMANDS
from api.cli.options import request_fields, request_options
from api.cli.procedures import procedure_command
from api.core.jobs import PROCEDURES
from api.http.routes.jobs import router
from daq.procedures.params import ParameterError
from daq.procedures.requests import Flag
from daq.procedures.run_kinds import KINDS, RIG_KINDS
from daq.procedures.sequence import parse_sequence
from daq.vocabulary import AXES, Axis, RunKind, RunStatus


def test_every_kind_has_one_entry_a_route_a_command_and_a_job():
    assert list(KINDS) == list(RunKind)
    assert set(KINDS) - set(RIG_KINDS) == {RunKind.DECAY}  # imported, never run on the rig
    routes = {r.path: r for r in router.routes if "POST" in getattr(r, "methods", ())}
    for kind, spec in RIG_KINDS.items():
        route = routes[f"/api/jobs/{spec.route}"]
        assert route.body_field is not None
        assert route.body_field.field_info.annotation is spec.request
        assert COMMANDS[spec.command][0] == "api.cli.procedures"
        assert kind in PROCEDURES


def test_stored_words_stay_plain_strings():
    assert json.dumps([RunKind.THRUST_CALIBRATION, RunStatus.INTERRUPTED]) == (
        '["thrust_calibration", "interrupted"]'
    )
    assert {RunKind.TOW: 1}["tow"] == 1  # rows from the database index the registry
    assert (AXES["tow"].axis, AXES["spin"].position_channel) == (Axis.SURGE, "yaw_angle")


def test_cli_options_come_from_the_request_model():
    command = procedure_command(KINDS[RunKind.TOW])
    options = {p.name: p for p in command.params if isinstance(p, click.Option)}
    force = options["force_n"]
    assert force.opts == ["--force"] and force.type is click.FLOAT
    assert force.help == KINDS[RunKind.TOW].request.model_fields["force_n"].description
    assert options["drive"].is_flag and options["drive"].opts == ["--thrusters"]
    assert options["baseline_s"].default == 1.0 and options["baseline_s"].show_default
    given = request_fields(KINDS[RunKind.TOW].request, {"force_n": 5.0, "drive": True})
    assert given == {"force_n": 5.0, "drive": "thrusters"}
    assert request_fields(KINDS[RunKind.TOW].request, {"force_n": None, "drive": False}) == {}


class _Toy(BaseModel):
    settle_s: Annotated[float, Field(ge=0, le=30, description="Settle, s."), Flag("--settle")] = 1.0
    commands: Annotated[
        list[float] | None,
        Field(description="a comma-separated list of numbers"),
        Flag("--commands", metavar="LIST", parse=lambda t: [float(x) for x in t.split(",")]),
    ] = None


@click.command()
@request_options(_Toy)
def _toy(**values):
    click.echo(json.dumps(request_fields(_Toy, values)))


def test_a_declared_range_becomes_the_options_range_and_names_the_flag():
    ok = CliRunner().invoke(_toy, ["--settle", "2.5", "--commands", "0,0.5"])
    assert ok.exit_code == 0, ok.output
    assert json.loads(ok.output) == {"settle_s": 2.5, "commands": [0.0, 0.5]}
    high = CliRunner().invoke(_toy, ["--settle", "31"])
    assert high.exit_code == 2 and "'--settle'" in high.output and "0<=x<=30" in high.output
    bad = CliRunner().invoke(_toy, ["--commands", "a,b"])
    assert bad.exit_code == 2 and "'--commands': got 'a,b'" in bad.output


def test_a_sequence_step_with_a_field_its_kind_does_not_have_is_refused(source):
    data = {"steps": [{"kind": "tow", "force_n": 4.9}, {"kind": "spin", "force_n": 1.0}]}
    with pytest.raises(ParameterError) as err:
        parse_sequence(data, source.rig)
    ((name, value, allowed),) = err.value.problems
    assert (name, value) == ("steps[1].force_n", 1.0)
    assert "torque_nm" in allowed and "max_angle_rad" in allowed


def test_every_act_a_kind_names_is_played_by_the_simulated_operator():
    """The acts are one table (``daq.operator.SIMULATED_ACTS``): a kind whose procedure asks
    for an act the simulated operator cannot play fails here, not on the simulated rig."""
    from daq.operator import SIM_CHANNEL, SIMULATED_ACTS, OperatorAct

    for spec in KINDS.values():
        for act in spec.acts:
            assert act in SIMULATED_ACTS, (spec.kind, act)
    assert {a for s in RIG_KINDS.values() for a in s.acts} == set(SIMULATED_ACTS)
    assert SIM_CHANNEL["pull_pendulum"] == "sim_pendulum_angle"
    hang = SIMULATED_ACTS["hang_tow_weight"].writes(OperatorAct("hang_tow_weight", "", 2.5, True))
    assert hang == [("sim_tow_weight", 2.5), ("sim_tow_reversed", True)]
    back = SIMULATED_ACTS["return_carriage"].writes(OperatorAct("return_carriage", "", 5.3))
    assert back == [("sim_carriage_position", 5.3)]


def test_a_kind_is_a_module_the_registry_discovers(tmp_path, monkeypatch):
    """A new kind is one file in daq/procedures/kinds: the registry (run_kinds.py) finds
    it without an edit and orders every kind by rank."""
    import sys

    from daq.procedures import kinds
    from daq.procedures.run_kinds import discover_kinds

    extra = tmp_path / "towed_array_kind.py"
    extra.write_text(
        "from daq.procedures.kind_spec import KindSpec\n"
        "from daq.vocabulary import RunKind\n"
        "SPEC = KindSpec(kind=RunKind.DECAY, rank=15, label='towed array', help='x')\n",
        encoding="utf-8",
    )
    monkeypatch.setattr(kinds, "__path__", [*kinds.__path__, str(tmp_path)])
    monkeypatch.delitem(sys.modules, "daq.procedures.kinds.towed_array_kind", raising=False)
    labels = [spec.label for spec in discover_kinds()]
    assert labels[:3] == ["tow test", "towed array", "spin test"]
    assert labels.count("towed array") == 1 and len(labels) == len(KINDS) + 1
    ranks = [spec.rank for spec in KINDS.values()]
    assert ranks == sorted(set(ranks))  # one place in every list per kind
