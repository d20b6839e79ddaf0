"""Tows and spins recorded on a live rig session, each run to completion (the chains'
recordings: tests/integration, the procedure tests)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from daq.procedures.motion import run_motion_test
from daq.procedures.params import spin_parameters, tow_parameters
from daq.procedures.thruster_drive import STALE_ZEROED
from daq.session import RigSession


async def completed_runs(
    session: RigSession, kind: str, drives: Iterable[float], **raw: Any
) -> list[str]:
    """One ``kind`` run ("tow": ``force_n`` in N, "spin": ``torque_nm`` in N·m) per drive,
    with the request's other fields ``raw``; each must complete. A thruster run the rig
    ended because a lost PLC poll zeroed its thrust (a loaded host) is run again, as an
    operator would; at most twice. Their run ids in order."""
    ids = []
    for drive in drives:
        if kind == "tow":
            params = tow_parameters(raw | {"force_n": drive}, session.rig)
        else:
            params = spin_parameters(raw | {"torque_nm": drive}, session.rig)
        for _ in range(3):
            outcome = await run_motion_test(session, params)
            if not (outcome.reason or "").startswith(STALE_ZEROED):
                break
            print(f"run again: {outcome.reason}")
        assert outcome.status == "completed", outcome
        ids.append(outcome.run_id)
    return ids
