"""Calibration tables as other tools write them: the published T200 table re-written as
Excel does (byte-order mark, ``;``, decimal commas), in lbf and gf, with commands in
per-mille, fractions and volts, reads back to the same newtons and fractions; bad cells
name their line and column."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest

from estimation.thrust.calibration_import import (
    THRUST_UNITS,
    CommandUnit,
    ImportSpec,
    read_calibration_csv,
)
from tests.support.shared_data import shared_file

T200 = Path(__file__).resolve().parents[3] / "fixtures" / "calibrations" / "t200-bollard.csv"
PWM = CommandUnit("pwm_us", 1500, 400)
SPEC = ImportSpec("PWM (µs)", "Force (Kg f)", "kgf", PWM, "Voltage (V)")


@pytest.fixture(scope="module")
def published() -> list[dict]:
    return read_calibration_csv(T200.read_bytes(), SPEC)


def _source() -> list[tuple[float, float, float]]:
    lines = [x for x in T200.read_text(encoding="utf-8").splitlines() if not x.startswith("#")]
    return [(float(p), float(v), float(f)) for p, v, f in csv.reader(lines[1:])]


def _write(rows, header, delimiter=",", decimal=".", bom=False) -> bytes:
    out = io.StringIO()
    writer = csv.writer(out, delimiter=delimiter, lineterminator="\r\n")
    writer.writerow(header)
    for row in rows:
        writer.writerow([f"{x:.10g}".replace(".", decimal) for x in row])
    return (b"\xef\xbb\xbf" if bom else b"") + out.getvalue().encode("utf-8")


def test_the_published_table_reads_as_fractions_and_newtons(published):
    assert len(published) == 5 * 51
    first = published[0]
    assert first == {
        "command": -1.0,
        "thrust_per_thruster_n": pytest.approx(-2.31 * 9.80665),
        "supply_voltage_v": 10.0,
    }
    assert {r["supply_voltage_v"] for r in published} == {10, 12, 16, 18, 20}
    assert max(r["command"] for r in published) == 1.0


def test_excel_semicolons_decimal_commas_and_bom_read_the_same(published):
    data = _write(_source(), ["PWM (µs)", "Voltage (V)", "Force (Kg f)"], ";", ",", bom=True)
    assert data.startswith(b"\xef\xbb\xbf") and b";" in data and b"," in data
    assert read_calibration_csv(data, SPEC) == published


@pytest.mark.parametrize("unit", ["lbf", "gf", "N"])
def test_thrust_units_convert_to_newtons(published, unit):
    rows = [(p, v, f * THRUST_UNITS["kgf"] / THRUST_UNITS[unit]) for p, v, f in _source()]
    data = _write(rows, ["pwm", "volts", f"thrust [{unit}]"])
    spec = ImportSpec("pwm", f"thrust [{unit}]", unit, PWM, "volts")
    got = read_calibration_csv(data, spec)
    assert [r["thrust_per_thruster_n"] for r in got] == pytest.approx(
        [r["thrust_per_thruster_n"] for r in published], rel=1e-9
    )


@pytest.mark.parametrize(
    ("command", "to_value"),
    [
        (CommandUnit("permille"), lambda pwm: (pwm - 1500) / 400 * 1000),
        (CommandUnit("fraction"), lambda pwm: (pwm - 1500) / 400),
        (CommandUnit("volts", full_scale_v=5.0), lambda pwm: (pwm - 1500) / 400 * 5.0),
        (CommandUnit("pwm_us", 1000, 1000), lambda pwm: 1000 + (pwm - 1500) / 400 * 1000),
    ],
)
def test_command_units_become_the_same_fractions(published, command, to_value):
    rows = [(to_value(p), f) for p, v, f in _source() if v == 16]
    data = _write(rows, ["cmd", "kgf"], "\t", ",")
    got = read_calibration_csv(data, ImportSpec("1", "2", "kgf", command, voltage_v=16))
    want = [r for r in published if r["supply_voltage_v"] == 16]
    assert [r["command"] for r in got] == pytest.approx([r["command"] for r in want], abs=1e-9)
    assert all(r["supply_voltage_v"] == 16 for r in got)


@pytest.mark.parametrize(
    ("text", "spec", "message"),
    [
        (
            "pwm;kgf\n1500;0\n1600;x,2\n",
            ImportSpec("pwm", "kgf", "kgf", PWM),
            "line 3, column 'kgf': got 'x,2'",
        ),
        (
            "pwm,kgf\n1500,0\n2100,1\n",
            ImportSpec("pwm", "kgf", "kgf", PWM),
            "line 3, column 'pwm': got 2100",
        ),
        (
            "# a comment\npwm,kgf\n1500,0\n1600,\n",
            ImportSpec("pwm", "kgf", "kgf", PWM),
            "line 4, column 'kgf': empty",
        ),
        (
            "pwm,kgf\n1500,0\n",
            ImportSpec("pwm", "lbs", "kgf", PWM),
            "no column 'lbs'; the table has 'pwm', 'kgf'",
        ),
        (
            "pwm,kgf,V\n1500,0,-3\n",
            ImportSpec("pwm", "kgf", "kgf", PWM, "V"),
            "line 2, column 'V': got -3",
        ),
        ("pwm,kgf\n", ImportSpec("pwm", "kgf", "kgf", PWM), "file: allowed a header line"),
    ],
)
def test_bad_cells_name_their_line_and_column(text, spec, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        read_calibration_csv(text.encode(), spec)


def test_bad_units_name_the_field():
    with pytest.raises(ValueError, match="thrust_unit: got 'kg', allowed: N, kgf, gf, lbf"):
        ImportSpec("1", "2", "kg")
    with pytest.raises(ValueError, match="command_unit: got 'us'"):
        CommandUnit("us")
    with pytest.raises(ValueError, match="full_scale_v"):
        CommandUnit("volts")


PUBLISHED_SPEC = ImportSpec("PWM (µs)", "Force (Kg f)", "kgf", PWM, "Voltage (V)")


@pytest.mark.parametrize("volts", [10, 12, 14, 16, 18, 20])
def test_the_published_t200_tables_keep_current_rpm_power_and_efficiency(volts):
    """Blue Robotics' tables carry RPM, current, power and efficiency (g/W) per command:
    the import keeps current, RPM and power by their headers, and the efficiency it derives
    (|F| / P) is the published one."""
    path = shared_file("thrusters", f"T200-{volts}V.csv")
    rows = read_calibration_csv(path.read_bytes(), PUBLISHED_SPEC)
    source = list(csv.DictReader(path.read_text(encoding="utf-8").splitlines(),
                                 skipinitialspace=True))  # fmt: skip
    assert len(rows) == len(source) > 100
    checked = 0
    for row, published in zip(rows, source, strict=True):
        assert row["current_a"] == pytest.approx(float(published["Current (A)"]))
        assert row["rpm"] == pytest.approx(float(published["RPM"]))
        assert row["power_w"] == pytest.approx(float(published["Power (W)"]))
        if float(published["Power (W)"]) > 1.0:  # the dead band's ~0 W rows: no efficiency
            grams_per_watt = row["efficiency_n_per_w"] / THRUST_UNITS["gf"]
            # Some rows of the sheet hold a rounded force or efficiency (14 V, 1548 µs: 0.1 kgf
            # → 71.4286 g/W for 71.2787; 20 V, 1124 µs: 8.5): agree within that rounding.
            published_gw = float(published["Efficiency (g/W)"])
            assert grams_per_watt == pytest.approx(published_gw, rel=5e-3)
            checked += 1
    assert checked > 100


def test_a_pwm_column_read_as_fractions_says_to_use_pwm_us():
    spec = ImportSpec("PWM (µs)", "Force (Kg f)", "kgf", CommandUnit(), "Voltage (V)")
    with pytest.raises(ValueError) as err:
        read_calibration_csv(T200.read_bytes(), spec)
    assert "got 1100, allowed: a command within full reverse … full forward (fraction)" in str(
        err.value
    )
    assert "1100 looks like a PWM pulse in µs: use command_unit pwm_us" in str(err.value)
