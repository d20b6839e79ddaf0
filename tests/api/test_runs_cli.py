"""``rig runs`` / ``show`` / ``annotate`` / ``import`` / ``export`` with run metadata, as
real subprocesses on a fresh database: filters, local days, paging, one-line errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.support.cli import RigCli

CSV = "t,position\n0,0\n0.1,0.01\n0.2,0.03\n"


@pytest.fixture
def rig(tmp_path: Path) -> RigCli:
    (tmp_path / "day1.csv").write_text(CSV)
    return RigCli(tmp_path)


def test_import_with_metadata_then_find_annotate_show_and_export(rig, tmp_path: Path) -> None:
    first = rig("import", "day1.csv", "--kind", "tow", "--force", "10", "--weight", "1.02",
                "--operator", "Ada", "--water-temp", "18.5", "--tag", "fins-v2",
                "--meta", "ballast=K3", "--meta", "depth_m=1.2").stdout.strip()  # fmt: skip
    second = rig("import", "day1.csv", "--kind", "spin", "--torque", "0.5").stdout.strip()

    def found(*filters: str) -> list[str]:
        return [r["id"] for r in json.loads(rig("runs", "--json", *filters).stdout)]

    assert found("--tag", "fins-v2") == [first]
    # a search also matches run ids: "k3" is no hex digit pair, so no random id can match it
    assert found("--search", "k3") == [first]
    assert found("--drive", "weight") == [first] and found("--drive", "none") == [second]
    assert set(found("--source", "imported", "--since", "today", "--until", "today")) == {
        first, second
    }  # fmt: skip
    assert found("--source", "recorded") == [] and found("--until", "yesterday") == []
    run = json.loads(rig("show", first[:8], "--json").stdout)
    assert run["metadata"] == {"operator": "Ada", "water_temperature_c": 18.5,
                               "tags": ["fins-v2"], "ballast": "K3", "depth_m": 1.2}  # fmt: skip
    assert (run["source"], run["source_file"], run["drive"]) == ("imported", "day1.csv", "weight")

    listed = rig("runs", "--limit", "1")
    assert first[:8] not in listed.stdout and second[:8] in listed.stdout
    assert "runs 1-1 of 2; --offset 1 for more" in listed.stderr
    assert first[:8] in rig("runs", "--limit", "1", "--offset", "1").stdout

    annotated = rig("annotate", first[:8], "--notes", "long fins", "--untag", "fins-v2",
                    "--tag", "repeat", "--unset", "ballast", "--json")  # fmt: skip
    assert json.loads(annotated.stdout) == {"operator": "Ada", "water_temperature_c": 18.5,
                                            "tags": ["repeat"], "depth_m": 1.2,
                                            "notes": "long fins"}  # fmt: skip
    shown = rig("show", first[:8]).stdout
    assert "imported" in shown and "from day1.csv" in shown and "notes      long fins" in shown
    # Parameters as labelled fields with units, not a Python dict.
    assert "parameters source import\n" in shown and "           force 10 N\n" in shown
    assert "           hung weight 1.02 kg\n" in shown
    assert "{" not in shown and "None" not in shown
    assert {"key": "force_n", "label": "force", "value": 10.0, "unit": "N", "shown": "10 N"} in (
        run["parameters_labelled"]
    )
    assert found("--search", "LONG FINS") == [first] and found("--tag", "fins-v2") == []

    rig("export", first, "-o", "out.csv")
    lines = (tmp_path / "out.csv").read_text().splitlines()
    metadata = next(line for line in lines if line.startswith("# metadata: "))
    assert json.loads(metadata.removeprefix("# metadata: "))["notes"] == "long fins"
    again = rig("import", "out.csv", "--kind", "tow", "--force", "10").stdout.strip()
    assert json.loads(rig("show", again, "--json").stdout)["metadata"]["notes"] == "long fins"


def test_bad_metadata_and_filters_end_in_one_line_naming_the_flag(rig) -> None:
    for argv, expect in (
        (
            ["--water-temp", "99"],
            "error: Invalid value for '--water-temp': 99.0 is not in the range -2.0<=x<=50.0",
        ),
        (["--tag", "two words"], "error: --tag: 'two words' is not allowed"),
        (["--meta", "Bad=1"], "error: --meta Bad: this key is not allowed"),
        (["--operator", " "], "error: --operator: ' ' is not allowed"),
    ):
        proc = rig("import", "day1.csv", "--kind", "tow", "--force", "1", *argv, code=2)
        assert proc.stderr.startswith(expect) and proc.stderr.count("\n") == 1, proc.stderr
    assert json.loads(rig("runs", "--json").stdout) == []  # nothing was imported
    proc = rig("runs", "--tag", "two words", code=2)
    assert proc.stderr.startswith("error: --tag: 'two words' is not allowed")
