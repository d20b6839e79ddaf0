"""Pendulum free decay through the full chain, with dry friction in the pivot nobody declared.

simulated rig (scenario: pivot Coulomb friction) → run_pendulum_decay over Modbus TCP →
acquisition clock → SQLite → daq.run_data.load_pendulum_data →
estimation.pendulum.pendulum_estimate (via the same ``run_estimation`` the CLI and the API
use). The estimator knows only the rig file's geometry; it must name the pivot friction,
size it, and return the scenario's surge added mass and damping. Run with ``-s`` to see the figures.
"""

from __future__ import annotations

import json
import math

import pytest
from click.testing import CliRunner

from api.cli.main import main as rig_cli
from api.core.estimation_job import run_estimation
from daq.config import DEFAULT_RIG_FILE
from daq.procedures.pendulum import run_pendulum_decay
from daq.procedures.requests import pendulum_parameters
from daq.session import RigSource
from daq.sim.scenario import parse_scenario
from daq.store import Store
from tests.support.simrig import rig_session

#: Slow lane: real-time runs on the simulated rig, then full estimations (minutes).
pytestmark = [pytest.mark.slow, pytest.mark.simtime]

#: A short, bottom-heavy pendulum (period ≈ 3.9 s) so ≈ 5 swings fit in a 20 s real-time run.
SHORT_PENDULUM = """
[pendulum]
pivot_to_vehicle_m = 0.6
rod_mass_kg = 7.88
rod_cg_m = 0.3
rod_inertia_kg_m2 = 0.95
vehicle_inertia_kg_m2 = 1.1
buoyancy_kg = 10.0
pivot_damping_nm_s = 0.228
max_angle_rad = 0.5
axis = "surge"
"""
PIVOT_FRICTION_NM = 0.8
#: The scenario's surge defaults (seed 000): α = inertia − BENBAM's 30 kg dry mass.
ALPHA, BETA, GAMMA = 143.26 - 30.0, 20.16, 241.14


def _source(tmp_path) -> RigSource:
    text = DEFAULT_RIG_FILE.read_text(encoding="utf-8")
    rig_file = tmp_path / "short-pendulum.toml"
    rig_file.write_text(text[: text.index("[pendulum]")] + SHORT_PENDULUM, encoding="utf-8")
    base = RigSource.load(rig_file)
    effects = {"pivot_coulomb_friction_nm": PIVOT_FRICTION_NM}
    scenario = parse_scenario({"name": "pivot-friction", "effects": effects})
    scenario_toml = 'name = "pivot-friction"\n[effects]\n' + "".join(
        f"{k} = {v}\n" for k, v in effects.items()
    )
    return RigSource(
        rig=base.rig, rig_toml=base.rig_toml, scenario=scenario, scenario_toml=scenario_toml
    )


def _print(label: str, data: dict) -> None:
    print(f"\n{label}: effects {[(e['name'], e['value'], e['std']) for e in data['effects']]}")
    for m in data["methods"]:
        q = m["quadratic_damping"]
        print(
            f"  {m['method']:<22} α {m['added_mass']['value']:9.3f} ± {m['added_mass']['std']:.3f}"
            f"  β {m['linear_damping']['value']:8.3f} ± {m['linear_damping']['std']:.3f}"
            f"  γ {'—' if q is None else format(q['value'], '.2f')}  e {m['mse']:.3g}"
        )
    print(f"  RMSE before {data['rmse_before']:.3g} rad, after {data['rmse_after']:.3g} rad")
    lb = data["diagnostics"]
    print(f"  Ljung–Box Q {lb['ljung_box_before']['q']:.1f} → {lb['ljung_box_after']['q']:.1f}")
    for w in data["warnings"]:
        print(f"  warning: {w}")


async def test_undeclared_pivot_friction_is_found_through_the_full_chain(tmp_path):
    store = Store(f"sqlite:///{tmp_path / 'rig.db'}")
    async with rig_session(_source(tmp_path), store) as session:
        params = pendulum_parameters(
            {
                "start_angle_rad": 0.3,
                "stop_amplitude_rad": 0.004,
                "max_time_s": 20,
                "baseline_s": 0.5,
            },
            session.rig,
        )
        outcome = await run_pendulum_decay(session, params)
    assert outcome.status == "completed", outcome
    base = run_estimation(store, [outcome.run_id], search_effects=False)
    data = run_estimation(store, [outcome.run_id], report_dir=tmp_path / "report")
    _print("base model (no effects)", base)
    _print("after the effect search", data)

    assert data["analysis"] == "pendulum" and data["axis"] == "surge"
    names = [e["name"] for e in data["effects"]]
    assert "coulomb_friction" in names
    # γ is in the plant too. A pendulum searches a free decay's candidates now (one engine):
    # on this simulated swing it also keeps a softening cubic stiffness of about −3 N·m/rad³,
    # 0.2 % of the restoring moment at the 0.3 rad start (cause not found: the plant's
    # stick-slip step is the suspect; the closing note of issue 31 says so). Anything else,
    # or a cubic stiffness that matters to the swing, is a false claim.
    assert set(names) <= {"coulomb_friction", "quadratic_damping", "cubic_stiffness"}
    for e in data["effects"]:
        if e["name"] == "cubic_stiffness":
            k = data["geometry"][outcome.run_id]
            restoring = ((k["vehicle_mass_kg"] - k["buoyancy_kg"]) * k["pivot_to_vehicle_m"]
                         + k["rod_mass_kg"] * k["rod_cg_m"]) * k["g"] * math.sin(0.3)  # fmt: skip
            assert abs(e["value"]) * 0.3**3 < 0.005 * restoring
    tau = next(e for e in data["effects"] if e["name"] == "coulomb_friction")
    assert tau["value"] == pytest.approx(PIVOT_FRICTION_NM, rel=0.1)
    c = data["coefficients"]
    assert c["added_mass"]["value"] == pytest.approx(ALPHA, rel=0.02)
    assert c["linear_damping"]["value"] == pytest.approx(BETA, rel=0.1)
    assert data["rmse_after"] < data["rmse_before"] / 5
    lb = data["diagnostics"]
    assert lb["ljung_box_after"]["q"] < lb["ljung_box_before"]["q"]
    # what is left is the encoder's resolution (4.8e-5 rad counts), not a missing effect
    assert data["rmse_after"] < 4.8e-5
    stored = store.results(outcome.run_id, kind="estimation")
    assert stored and stored[-1].data["analysis"] == "pendulum"
    assert (tmp_path / "report" / "peaks.png").is_file()
    store.close()


def _other_kind_run(store: Store, rig_toml: str) -> str:
    """A (sample-less) tow run next to the pendulum run: enough to test the kind check."""
    return store.import_run(
        kind="tow",
        parameters={"force_n": 24.5},
        channel_names=["tow_position"],
        rig_name="BENBAM tow tank",
        vehicle="BENBAM",
        rig_toml=rig_toml,
        samples=[],
        started_at=0.0,
        stopped_at=1.0,
    )


async def test_pendulum_runs_through_the_cli_with_methods_checked_per_kind(tmp_path):
    db = f"sqlite:///{tmp_path / 'rig.db'}"
    store = Store(db)
    source = _source(tmp_path)
    async with rig_session(source, store) as session:
        params = pendulum_parameters(
            {
                "start_angle_rad": 0.2,
                "stop_amplitude_rad": 0.02,
                "max_time_s": 8,
                "baseline_s": 0.3,
            },
            session.rig,
        )
        outcome = await run_pendulum_decay(session, params)
    run_id = outcome.run_id
    tow_id = _other_kind_run(store, source.rig_toml)
    store.close()

    cli = CliRunner()
    done = cli.invoke(rig_cli, ["estimate", run_id, "--db", db, "--method", "damped-fit", "--json"])
    assert done.exit_code == 0, done.output
    data = json.loads(done.output)
    assert data["analysis"] == "pendulum" and data["method"] == "damped-fit"
    row = next(m for m in data["methods"] if m["method"] == "damped-fit")
    assert data["coefficients"]["added_mass"]["value"] == pytest.approx(row["added_mass"]["value"])
    text = cli.invoke(rig_cli, ["estimate", run_id, "--db", db, "--no-effects"])
    assert text.exit_code == 0, text.output
    assert "log-decrement" in text.output and "RMSE before" in text.output

    wrong = cli.invoke(rig_cli, ["estimate", run_id, "--db", db, "--method", "ls-raw"])
    assert wrong.exit_code != 0
    assert "method: 'ls-raw' is not allowed for pendulum runs" in wrong.output
    assert "allowed: output-error, damped-fit, log-decrement, equation-error" in wrong.output
    mixed = cli.invoke(rig_cli, ["estimate", run_id, tow_id, "--db", db])
    assert mixed.exit_code != 0
    assert "mixed kinds ['pendulum', 'tow']" in mixed.output
    tow_only = cli.invoke(rig_cli, ["estimate", tow_id, "--db", db, "--method", "damped-fit"])
    assert "method: 'damped-fit' is not allowed for tow/spin runs" in tow_only.output
