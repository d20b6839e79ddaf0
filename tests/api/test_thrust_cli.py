"""``rig import-calibration`` and ``rig thrust`` as real subprocesses on the synthetic
motor thruster's table (Excel's decimal-comma CSV): the law answers a voltage left out of
the table within 2 % of full thrust, and a force below the smallest calibrated thrust is
one error line naming that thrust."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from estimation.thrust.calibration_import import CommandUnit, ImportSpec, read_calibration_csv
from tests.estimation.motor_thruster import KGF, calibration_csv, full_thrust_n, thrust_n
from tests.support.cli import RigCli

CALIBRATED = (10.0, 12.0, 14.0, 18.0, 20.0)


@pytest.fixture
def rig(tmp_path: Path) -> RigCli:
    return RigCli(tmp_path)


def test_import_the_table_then_ask_a_held_out_voltage_and_a_too_small_force(rig, tmp_path):
    (tmp_path / "stand.csv").write_bytes(calibration_csv(CALIBRATED))
    made = rig("import-calibration", "stand.csv", "--command-column", "PWM (µs)",
               "--command-unit", "pwm_us", "--thrust-column", "Schub (kgf)",
               "--thrust-unit", "kgf", "--voltage-column", "Spannung (V)", "--json")  # fmt: skip
    made = json.loads(made.stdout)
    assert made["law"]["voltages_v"] == list(CALIBRATED)
    listed = rig("calibrations").stdout
    assert (
        f"imported {made['id']} (stand.csv): {len(_rows())} rows at 10, 12, 14, 18, 20 V" in listed
    )
    # Without --voltage, and no supply recorded on the rig: the calibration's reference.
    text = rig("thrust", "--command", "1").stdout.splitlines()
    assert text[1].startswith("supply: 20 V, the calibration's reference")
    assert text[2].startswith(f"calibration: imported {made['id']} (stand.csv);")

    full = full_thrust_n(CALIBRATED)
    for pwm in (1600, 1800, 1900, 1200):
        out = json.loads(rig("thrust", "--command", str((pwm - 1500) / 400), "--voltage", "16",
                             "--json").stdout)  # fmt: skip
        assert abs(out["force_n"]["value"] - thrust_n(pwm, 16.0)) < 0.02 * full
        assert out["force_n"]["std"] > 0 and "identified" in out["voltage_law"]

    # The smallest thrust the table measured at 14 V: the first reading beyond the last
    # that measured none (the dead band, ±25 µs, reads noise about zero). A quarter of it
    # is refused, naming it.
    at14 = sorted(
        (r["command"], r["thrust_per_thruster_n"]) for r in _rows() if r["supply_voltage_v"] == 14
    )
    edge = max(u for u, f in at14 if u >= 0 and f <= 0)
    smallest, small = min((u, f) for u, f in at14 if u > edge)
    assert 0.05 < smallest <= 0.125 and 0 < small < 0.3 * KGF
    error = rig("thrust", "--force", f"{small / 4:.4f}", "--voltage", "14", code=2).stderr
    assert error.count("\n") == 1 and error.startswith("error: --force: got ")
    assert f"allowed: at least {small:.4g} N forward at 14 V" in error
    assert f"the smallest calibrated thrust, command {smallest:g}" in error
    answer = json.loads(rig("thrust", "--force", f"{small * 1.01:.4f}", "--voltage", "14",
                            "--json").stdout)  # fmt: skip
    assert smallest < answer["command"]["value"] < smallest + 0.0625


def _rows() -> list[dict]:
    spec = ImportSpec(
        "PWM (µs)", "Schub (kgf)", "kgf", CommandUnit("pwm_us", 1500, 400), "Spannung (V)"
    )
    return read_calibration_csv(calibration_csv(CALIBRATED), spec)
