"""Pre-test uncertainty of a planned sequence (``rig predict-uncertainty``, ``POST
/api/uncertainty/predict``): the sequence checked against the rig file, each axis's current
model taken from the newest stored output-error estimate (or the results named), and
``estimation.uncertainty.planned_uncertainty`` run on plain numbers."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, cast

from pydantic import BaseModel, ConfigDict, Field

from daq.axis_budget import chain_of, tolerances_of
from daq.config import RigConfig
from daq.procedures.flag import Flag
from daq.procedures.run_kinds import KINDS
from daq.procedures.sequence import load_sequence
from daq.store import Store
from daq.vocabulary import AXES
from estimation.uncertainty.planned_uncertainty import PlannedRig, PlannedRun, predict_uncertainty

#: Release instant σ assumed when no stored run says otherwise, s: the brake write's
#: bracket on the simulated rig's Modbus (a few ms); ``release_std_s`` overrides it.
DEFAULT_RELEASE_STD_S = 0.002


class PretestQuery(BaseModel):
    """What a pre-test prediction takes, declared once: ``GET
    /api/sequences/{name}/uncertainty``'s query and ``rig predict-uncertainty``'s options."""

    model_config = ConfigDict(frozen=True)

    release_std_s: Annotated[
        float,
        Field(ge=0, le=1, description="1σ of each release instant, s."),
        Flag("--release-std", metavar="S"),
    ] = DEFAULT_RELEASE_STD_S
    result: Annotated[
        list[Annotated[int, Field(ge=1, le=2**62)]],
        Field(default_factory=list, max_length=4,
              description="Stored estimation results to take each axis's model from "
              "(default: the newest output-error estimate of each axis)."),
        Flag("--result", metavar="RESULT_ID"),
    ]  # fmt: skip


def current_models(store: Store, result_ids: Sequence[int] = ()) -> dict[str, list[float]]:
    """(M, K_L, K_Q) per axis from the named results, else the newest output-error estimate
    of each axis."""
    found = (
        [store.result(i) for i in result_ids] if result_ids else store.results(kind="estimation")
    )
    models: dict[str, list[float]] = {}
    for info in found:
        data = info.data
        if data.get("method") != "output-error" or "coefficients" not in data:
            continue
        c = data["coefficients"]
        models[data["axis"]] = [
            c[n]["value"] for n in ("inertia", "linear_damping", "quadratic_damping")
        ]
    return models


def planned_runs(rig: RigConfig, sequence_path: str | Path) -> list[PlannedRun]:
    """The weight-driven steps of a sequence file on the planner's driven axes (the kinds
    with an ``envelope`` and a drive: tows and spins); other steps (a pendulum's release
    among them) are not predicted."""
    seq = load_sequence(sequence_path, rig)
    out = []
    for step in seq.steps:
        if KINDS[step.kind].envelope is None or AXES[step.kind].drive_key is None:
            continue
        terms, signed = AXES[step.kind], cast(Any, step)  # a tow's or a spin's request
        if signed.drive == "weight" and signed.hung_mass_kg:
            # checked parameters: the load, the travel and the time limit are set
            load, travel = (
                getattr(signed, str(terms.drive_key)),
                getattr(signed, str(terms.travel_key)),
            )
            assert load is not None and travel is not None and signed.max_time_s is not None
            out.append(
                PlannedRun(
                    str(terms.axis),
                    load,
                    signed.hung_mass_kg,
                    travel,
                    signed.max_time_s,
                    seq.repeats,
                )
            )
    if not out:
        raise ValueError(
            f"sequence: got {sequence_path}, allowed: a sequence with weight-driven tows or spins"
        )
    return out


def predict_sequence(
    store: Store,
    rig: RigConfig,
    sequence_path: str | Path,
    result_ids: Sequence[int] = (),
    release_std_s: float = DEFAULT_RELEASE_STD_S,
) -> dict[str, Any]:
    """{"sequence", "models", "tolerances", "axes": {axis: budget JSON}} of the plan."""
    if not 0 <= release_std_s <= 1:
        raise ValueError(f"release_std_s: got {release_std_s}, allowed: 0 … 1 s")
    planned = planned_runs(rig, sequence_path)
    models = current_models(store, result_ids)
    missing = sorted({p.axis for p in planned} - set(models))
    if missing:
        raise ValueError(
            f"model: got no stored estimate for {', '.join(missing)}, allowed: a stored "
            "output-error estimate of each axis the sequence drives (estimate a first campaign, "
            "or name results with --result)"
        )
    steps = {  # the encoder step of each planned axis's position channel (1e-4 without one)
        str(AXES[kind].axis): (
            abs(rig.channel(AXES[kind].position_channel).scale)
            if rig.has(AXES[kind].position_channel)
            else 1e-4
        )
        for kind, spec in KINDS.items()
        if spec.envelope is not None and AXES[kind].drive_key is not None
    }
    planned_rig = PlannedRig(
        chain_of(rig), rig.acquisition.rate_hz, steps, release_std_s=release_std_s
    )
    tolerances = tolerances_of(rig)
    budgets = predict_uncertainty(planned, models, planned_rig, tolerances)
    return {
        "sequence": str(sequence_path),
        "models": models,
        "tolerances": tolerances,
        "release_std_s": release_std_s,
        "axes": {axis: b.to_json() for axis, b in budgets.items()},
    }
