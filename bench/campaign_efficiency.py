"""Campaign vs the seed's fixed test matrix: runs, tank minutes and final uncertainty (JSON).

On the in-process simulated rig in simulated time (``daq.sim.inprocess``), for the clean
and the dry-friction scenario: (a) ``fixtures/sequences/seed000-campaign.toml`` as it
stands, then both axes estimated; (b) a campaign (``estimation.design``) with target U ≤ 1 %
(the expanded uncertainty of the GUM budget with the rig file's tolerances) on inertia, K_L
and K_Q of surge and yaw, ambiguities resolved. Each fit's U and its error against the
scenario's coefficients are reported (``within_U``: every |error| ≤ U). Tank minutes = the
simulated run durations (first to last sample) + the rest between runs (the sequence's
``rest_s`` = the campaign's reset time, 30 s) after every run.

``--tolerances declared`` (default) runs with BENBAM's ``[tolerances]``: U carries their
Type B, and where that alone is above the target the campaign stops as out of reach.
``--tolerances none`` runs with the section removed: U is the Type A budget (the fit σ and
the release timing), which is what more runs reduce — the efficiency of the choice of runs.
Usage::

    python bench/campaign_efficiency.py [--scenario clean] [--target 0.01] [--tolerances none]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from api.core.campaign_session import run_campaign  # noqa: E402
from api.core.rig_envelope import envelope_of  # noqa: E402
from daq.axis_budget import fitted_budget  # noqa: E402
from daq.procedures.sequence import load_sequence, run_sequence  # noqa: E402
from daq.run_data import load_run_data, run_data_of  # noqa: E402
from daq.session import RigSession, RigSource  # noqa: E402
from daq.sim.inprocess import open_inprocess_rig  # noqa: E402
from daq.sim.simtime import SimClock  # noqa: E402
from daq.store import Store  # noqa: E402
from estimation import estimate  # noqa: E402
from estimation.design.campaign_state import Campaign, Target  # noqa: E402
from estimation.design.planner import state_from_result  # noqa: E402

SCENARIOS = {"clean": "clean.toml", "dry-friction": "coulomb-friction.toml"}
SEED = ROOT / "fixtures/sequences/seed000-campaign.toml"
REST_S = 30.0


def _seconds(store: Store, run_id: str) -> float:
    t = load_run_data(store, run_id).t
    return float(t[-1] - t[0])


def _truth(source: RigSource, axis: str) -> dict[str, float]:
    """The scenario's M, K_L, K_Q of ``axis`` (SI)."""
    scenario = source.scenario
    assert scenario is not None
    if axis == "surge":
        s = scenario.surge
        return {"inertia": s.inertia_kg, "linear_damping": s.linear_damping,
                "quadratic_damping": s.quadratic_damping}  # fmt: skip
    y = scenario.yaw
    return {"inertia": y.inertia_kg_m2, "linear_damping": y.linear_damping,
            "quadratic_damping": y.quadratic_damping}  # fmt: skip


def _summary(
    store: Store, ids: list[str], relative: float, truth: dict[str, float]
) -> dict[str, Any]:
    """U/|θ| in % of the fit of ``ids`` (the budget's U), its error against the scenario's
    ``truth`` in %, whether |error| ≤ U, what is unresolved, the effects."""
    records = [store.get_run(r) for r in ids]  # read once, as an estimate does
    runs = [run_data_of(store, run) for run in records]
    result = estimate(runs, n_bootstrap=0)
    state = state_from_result(result, [], fitted_budget(records, runs, result))
    ratios = state.ratios(relative)
    expanded = {n: r * relative * 100 for n, r in ratios.items()}
    error = {n: (state.values[n] / t - 1) * 100 for n, t in truth.items()}
    return {
        "expanded_percent": {n: round(u, 4) for n, u in expanded.items()},
        "error_percent": {n: round(e, 4) for n, e in error.items()},
        "within_U": all(abs(error[n]) <= expanded[n] for n in truth),
        "unresolved": state.unresolved(),
        "effects": [e.name for e in result.effects],
    }


def _session(source: RigSource, store: Store) -> RigSession:
    return RigSession(source, store, clock=SimClock.of_running_loop(), devices=open_inprocess_rig)


async def _seed(source: RigSource, store: Store, relative: float) -> dict[str, Any]:
    async with _session(source, store) as session:
        outcome = await run_sequence(session, load_sequence(SEED, source.rig))
    ids = [r.run_id for r in outcome.runs]
    kinds = [store.get_run(r).kind for r in ids]
    seconds = sum(_seconds(store, r) for r in ids)
    axes = {}
    for kind, axis in (("tow", "surge"), ("spin", "yaw")):
        mine = [r for r, k in zip(ids, kinds, strict=True) if k == kind]
        axes[axis] = _summary(store, mine, relative, _truth(source, axis))
    return {
        "runs": len(ids),
        "tank_minutes": round((seconds + REST_S * len(ids)) / 60, 2),
        "axes": axes,
    }


async def _campaign(source: RigSource, store: Store, relative: float) -> dict[str, Any]:
    campaign = Campaign(Target(relative), envelope_of(source.rig, store, reset_s=REST_S))
    async with _session(source, store) as session:
        await run_campaign(session, campaign)
    doc = campaign.to_json()
    return {
        "runs": doc["runs_used"],
        "tank_minutes": doc["tank_minutes"],
        "outcome": doc["outcome"],
        "axes": {
            a: _summary(store, campaign.run_ids(a), relative, _truth(source, a))
            for a in campaign.target.axes
        },
        "trail": [
            {k: e[k] for k in ("axis", "test", "run_s", "tank_minutes", "after")}
            for e in doc["trail"]
        ],
    }


def _rig_file(tolerances: str, folder: str) -> Path:
    """BENBAM's rig file, without its ``[tolerances]`` section when ``tolerances`` is none."""
    path = ROOT / "fixtures/rigs/benbam.toml"
    if tolerances == "declared":
        return path
    kept, skipping = [], False
    for line in path.read_text(encoding="utf-8").splitlines():
        if line.startswith("["):
            skipping = line.strip() == "[tolerances]"
        if not skipping:
            kept.append(line)
    out = Path(folder) / "benbam-no-tolerances.toml"
    out.write_text("\n".join(kept) + "\n", encoding="utf-8")
    return out


def bench(scenario: str, relative: float, tolerances: str = "declared") -> dict[str, Any]:
    """Both ways on ``scenario``; each in its own store."""
    folder = tempfile.mkdtemp()
    source = RigSource.load(
        _rig_file(tolerances, folder),
        scenario_file=ROOT / "fixtures/scenarios" / SCENARIOS[scenario],
    )
    out: dict[str, Any] = {"scenario": scenario}
    for name, run in (("seed_sequence", _seed), ("campaign", _campaign)):
        with tempfile.TemporaryDirectory() as tmp, Store(f"sqlite:///{tmp}/rig.db") as store:
            wall = time.perf_counter()
            out[name] = SimClock.run(run(source, store, relative))
            out[name]["wall_s"] = round(time.perf_counter() - wall, 1)
    out["tank_time_ratio"] = round(
        out["campaign"]["tank_minutes"] / out["seed_sequence"]["tank_minutes"], 3
    )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", choices=[*SCENARIOS, "all"], default="all")
    parser.add_argument("--target", type=float, default=0.01, help="U/|θ| target (0.01 = 1 %%)")
    parser.add_argument("--tolerances", choices=("declared", "none"), default="declared")
    args = parser.parse_args()
    names = list(SCENARIOS) if args.scenario == "all" else [args.scenario]
    results = [bench(n, args.target, args.tolerances) for n in names]
    doc = {"target_expanded": args.target, "tolerances": args.tolerances, "results": results}
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
