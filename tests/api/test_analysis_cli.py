"""``rig sensitivity``: the table, the JSON document, AHP from a file, errors."""

from __future__ import annotations

import json

import pytest
from click.testing import CliRunner

from api.cli.analysis import sensitivity

RESPONSES = ["--response", "steady_surge_speed", "--response", "steady_yaw_rate"]


def test_table_lists_ranking_sweep_and_advice():
    result = CliRunner().invoke(
        sensitivity, ["benbam", *RESPONSES, "--threshold", "0.05", "--keep", "added_mass.surge"]
    )
    assert result.exit_code == 0, result.output
    out = result.output
    assert "ranking (knock-out Sc per response" in out
    assert "threshold sweep" in out and "0.05" in out
    lines = [ln for ln in out.splitlines() if ln.startswith("added_mass.surge")]
    assert lines and lines[0].endswith("keep")
    assert "next test:" in out
    assert "weights: doubling or halving" in out


def test_json_with_ahp_file_matches_the_weights(tmp_path):
    path = tmp_path / "ahp.json"
    path.write_text(
        json.dumps(
            {
                "name": "mine",
                "matrix": [[1, 3], [1 / 3, 1]],
                "labels": ["steady_surge_speed", "steady_yaw_rate"],
            }
        )
    )
    result = CliRunner().invoke(sensitivity, ["benbam", *RESPONSES, "--ahp", str(path), "--json"])
    assert result.exit_code == 0, result.output
    out = json.loads(result.output)
    assert out["weights"] == pytest.approx({"steady_surge_speed": 0.75, "steady_yaw_rate": 0.25})
    for row in out["ranking"]:
        expected = 0.75 * row["sc"]["steady_surge_speed"] + 0.25 * row["sc"]["steady_yaw_rate"]
        assert row["composite"] == pytest.approx(expected)


@pytest.mark.parametrize(
    ("args", "text"),
    [
        (["nope"], "no vehicle named 'nope'"),
        (["benbam", "--keep", "drag.surge"], "keep: 'drag.surge' is not allowed"),
        (["benbam", "--weight", "steady_surge_speed"], "--weight: got 'steady_surge_speed'"),
        (["benbam", *RESPONSES, "--weight", "speed=1"], "weights: 'speed' is not allowed"),
    ],
)
def test_errors_exit_2_naming_the_field(args, text):
    result = CliRunner().invoke(sensitivity, args)
    assert result.exit_code == 2
    assert text in result.output
